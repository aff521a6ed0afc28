// The service worker that shows an alert sent by Web Push, even with every tab closed.
self.addEventListener("push", (event) => {
  let alert = {};
  try { alert = event.data ? event.data.json() : {}; } catch { alert = { text: event.data?.text() ?? "" }; }
  event.waitUntil(self.registration.showNotification(`Cyborg: ${alert.severity ?? "alert"}`, {
    body: alert.text ?? "", tag: alert.id, timestamp: (alert.started_at ?? Date.now() / 1000) * 1000,
    requireInteraction: alert.severity === "critical",
  }));
});

self.addEventListener("notificationclick", (event) => {
  event.notification.close();
  event.waitUntil(self.clients.openWindow("/"));
});
