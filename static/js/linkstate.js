// The robot link's status in words: one reading for the header pill and the dashboard's Connection
// card, so the two never disagree.
const up = (text) => text[0].toUpperCase() + text.slice(1);

export function linkState(s) {
  if (s.server_down) {
    return { ok: false, label: "server unreachable",
      why: "This page lost its connection to the web server (stopped, restarting or out of reach): retrying…" };
  }
  if (s.connected) return { ok: true, label: "robot online", why: "" };
  if (s.link_running === false) {
    return { ok: false, label: "link down", why: "The server's robot link is not running: nothing reaches the robot" };
  }
  if (s.command_path === false) {
    return { ok: false, label: "command path down",
      why: "The robot link does not answer requests: commands, including E-STOP, cannot reach the robot" };
  }
  if (s.robot_connected && s.responding === false) {
    return { ok: false, label: "not responding",
      why: "Connected, but the robot has not answered for a while: commands are refused until it does" };
  }
  return { ok: false, label: "robot offline", why: "" };
}

export const heading = (state) => up(state.label);
