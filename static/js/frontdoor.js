// The Connect a ROS tool page: a ticket to copy, and a roslibjs (vendored, unmodified) check of the
// front door from this browser: list the robot's topics through rosapi and watch one.
import { attempt, postJSON } from "./api.js";

const config = JSON.parse(document.getElementById("frontdoor-config").textContent);
const $ = (id) => document.getElementById(id);

$("frontdoor-ticket").addEventListener("click", async () => {
  const answer = await attempt(postJSON(config.urls.ticket), { context: "Ticket" });
  if (answer) $("frontdoor-url").textContent = answer.url;
});

let ros = null;
$("frontdoor-check").addEventListener("click", async () => {
  if (ros) ros.close();
  const answer = await attempt(postJSON(config.urls.ticket), { context: "Ticket" });
  if (!answer) return;
  $("frontdoor-state").textContent = "Connecting…";
  ros = new ROSLIB.Ros({ url: answer.url });
  ros.on("connection", () => {
    $("frontdoor-state").textContent = "Connected through the front door.";
    ros.getTopics((result) => { $("frontdoor-topics").textContent = String(result.topics.length); },
      (error) => { $("frontdoor-topics").textContent = `refused: ${error}`; });
    new ROSLIB.Topic({ ros, name: config.watch.name, messageType: config.watch.type })
      .subscribe((msg) => { $("frontdoor-value").textContent = JSON.stringify(msg.data); });
  });
  ros.on("error", () => { $("frontdoor-state").textContent = "Could not connect."; });
  ros.on("close", () => { $("frontdoor-state").textContent = "Disconnected."; });
});
