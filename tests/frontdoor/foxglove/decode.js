// Test-only: decode serialized ROS messages the way Foxglove's Rosbridge connection does, with
// Foxglove's own parsers. stdin: {"ros": 1|2, "messages": [{"type", "definition", "bytes_b64"}]}
// stdout: the decoded messages as JSON (typed arrays as arrays, times as {sec, nsec}).
"use strict";
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg-serialization");
const { MessageReader: Ros2MessageReader } = require("@foxglove/rosmsg2-serialization");

function plain(value) {
  if (typeof value === "bigint") return Number(value);
  if (ArrayBuffer.isView(value)) return Array.from(value, plain);
  if (Array.isArray(value)) return value.map(plain);
  if (value && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, plain(v)]));
  }
  return value;
}

let input = "";
process.stdin.on("data", (chunk) => (input += chunk));
process.stdin.on("end", () => {
  const request = JSON.parse(input);
  const readers = new Map();
  const out = request.messages.map((m) => {
    let reader = readers.get(m.type);
    if (!reader) {
      const definitions = parse(m.definition, { ros2: request.ros === 2 });
      reader = request.ros === 2 ? new Ros2MessageReader(definitions) : new MessageReader(definitions);
      readers.set(m.type, reader);
    }
    return plain(reader.readMessage(Buffer.from(m.bytes_b64, "base64")));
  });
  process.stdout.write(JSON.stringify(out, (k, v) => (typeof v === "number" && !Number.isFinite(v) ? null : v)));
});
