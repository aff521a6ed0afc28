// The keyboard-shortcut help on "?": every page lists the keys it answers to (what the page shows
// decides: the drive card, the talk button, the state-machine graph, the E-STOP button).
const PAGE_KEYS = [
  { when: "#estop-btn", keys: [["Esc", "E-STOP: stop the robot (on every page; with a dialog open, such as this one, Esc closes the dialog)"]] },
  { when: "#drive[data-can-drive=true]", keys: [
    ["W or ↑", "drive forward (hold)"], ["S or ↓", "drive backward (hold)"],
    ["A or ←", "turn left (hold)"], ["D or →", "turn right (hold)"],
    ["", "letting go of every key stops the robot"]] },
  { when: "#audio-talk", keys: [["T", "talk through the robot's speakers (hold)"]] },
  { when: "#smach-graph", keys: [["Tab, then Enter or Space", "send the focused transition's event"]] },
  { when: "body", keys: [["?", "this list of shortcuts"]] },
];

let dialog = null;

function typing(el) {
  return el && (el.isContentEditable || ["INPUT", "TEXTAREA", "SELECT"].includes(el.tagName));
}

function build() {
  dialog = document.createElement("dialog");
  dialog.className = "shortcuts";
  dialog.id = "shortcuts";
  dialog.setAttribute("aria-labelledby", "shortcuts-title");
  const head = document.createElement("div");
  head.className = "shortcuts-head";
  const title = document.createElement("h2");
  title.id = "shortcuts-title";
  title.textContent = "Keyboard shortcuts on this page";
  const close = document.createElement("button");
  close.type = "button";
  close.className = "btn";
  close.textContent = "Close";
  close.addEventListener("click", () => dialog.close());
  head.append(title, close);
  const list = document.createElement("dl");
  list.className = "shortcuts-list";
  for (const group of PAGE_KEYS) {
    if (!document.querySelector(group.when)) continue;
    for (const [key, what] of group.keys) {
      const dt = document.createElement("dt");
      for (const [i, part] of key.split(/( or |, then )/).entries()) {
        if (i % 2) dt.append(part);
        else if (part) { const kbd = document.createElement("kbd"); kbd.textContent = part; dt.append(kbd); }
      }
      const dd = document.createElement("dd");
      dd.textContent = what;
      list.append(dt, dd);
    }
  }
  dialog.append(head, list);
  dialog.addEventListener("click", (ev) => { if (ev.target === dialog) dialog.close(); }); // a click outside
  document.body.append(dialog);
}

export function toggleShortcuts() {
  if (!dialog) build();
  if (dialog.open) dialog.close();
  else dialog.showModal();
}

document.addEventListener("keydown", (ev) => {
  if (ev.key !== "?" || ev.ctrlKey || ev.metaKey || ev.altKey || typing(ev.target)) return;
  ev.preventDefault();
  toggleShortcuts();
});
