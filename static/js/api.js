// Fetch for every page: JSON in and out, the CSRF token on writes, one error shape
// (ApiError with the server's message, status and body), and the notices that report it.
import { notify } from "./notices.js";

export { notify };

export class ApiError extends Error {
  constructor(message, status, data) {
    super(message);
    this.status = status;
    this.data = data;
  }
}

export function csrfToken() {
  const m = document.cookie.match(/(?:^|; )csrftoken=([^;]+)/);
  return m ? decodeURIComponent(m[1]) : "";
}

// method + URL (+ JSON body) → the JSON answer ({} when empty); ApiError when not 2xx.
export async function request(method, url, body) {
  const headers = { Accept: "application/json" };
  if (method !== "GET") {
    headers["X-CSRFToken"] = csrfToken();
    headers["Content-Type"] = "application/json";
  }
  let res;
  try {
    res = await fetch(url, {
      method, headers, credentials: "same-origin",
      body: body === undefined ? undefined : JSON.stringify(body),
    });
  } catch {
    throw new ApiError("The server cannot be reached.", 0, {});
  }
  const data = res.status === 204 ? {} : await res.json().catch(() => ({}));
  if (!res.ok) {
    const message = data.detail || data.message || `Request failed (${res.status})`;
    throw new ApiError(res.status === 429 ? `Too many requests: ${message}` : message, res.status, data);
  }
  return data;
}

export const getJSON = (url) => request("GET", url);
export const postJSON = (url, body = {}) => request("POST", url, body);
export const deleteJSON = (url) => request("DELETE", url);

// Run a request and report a failure as a notice; resolves to the answer or null.
export async function attempt(promise, { context = "" } = {}) {
  try {
    return await promise;
  } catch (err) {
    notify(context ? `${context}: ${err.message}` : err.message, "error");
    return null;
  }
}
