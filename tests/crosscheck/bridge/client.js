// Cross-check of `cowork bridge` with Foxglove's own client packages, the ones the Foxglove app
// uses: @foxglove/ws-protocol for the connection, @foxglove/rosmsg to parse the advertised
// ros2msg schemas and @foxglove/rosmsg2-serialization to decode the CDR payloads.
//
//   node client.js ws://127.0.0.1:PORT TIMEOUT_S [STATS.json]
//
// Passes (exit 0) when, before TIMEOUT_S: at least 50 /joint_states (every one with 7 named,
// finite positions), 5 /tf (every one with frames and finite, unit-quaternion transforms),
// 3 depth images (width*height*bytes per pixel = data length = step*height, some valid depth),
// the latched /robot_description (a URDF) and one of its meshes fetched as an asset, byte for
// byte the file on disk. Every channel must be ros2msg + cdr and every payload must decode
// whole (no bytes left over beyond CDR padding). Prints (and writes) the per-topic end-to-end
// latency: the message's log time (the bridge's DDS receive time) to its arrival here.
"use strict";

const fs = require("fs");
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");
const WebSocket = require("ws");

const [url, timeoutArg, statsPath, measureArg] = process.argv.slice(2);
if (!url || !timeoutArg) {
  console.error("usage: node client.js ws://HOST:PORT TIMEOUT_S [STATS.json [MEASURE_S]]");
  process.exit(2);
}
// With MEASURE_S, keep receiving (and checking) for that long after the checks pass, for
// steady-state figures; otherwise stop as soon as they pass.
const measureMs = Number(measureArg || 0) * 1000;
const started = Date.now();
const WANT = { "/joint_states": 50, "/tf": 5, "/camera/depth/image_raw": 3, "/robot_description": 1 };
const counts = Object.fromEntries(Object.keys(WANT).map((t) => [t, 0]));
const latencies = Object.fromEntries(Object.keys(WANT).map((t) => [t, []]));
const subscriptions = new Map(); // subscription id -> { topic, reader }
const failures = [];
let asset = { requested: false, ok: false, uri: null };

// The SDK's server (the `foxglove` crate, as foxglove_bridge 3.2+) speaks the v1 protocol under
// the subprotocol name "foxglove.sdk.v1"; the Foxglove app offers it beside the older
// "foxglove.websocket.v1" (FoxgloveClient.SUPPORTED_SUBPROTOCOL), and so do we.
const SDK_SUBPROTOCOL = "foxglove.sdk.v1";
const ws = new WebSocket(url, [SDK_SUBPROTOCOL, FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
ws.on("open", () => {
  if (ws.protocol !== SDK_SUBPROTOCOL) fail(`negotiated subprotocol ${ws.protocol}, not ${SDK_SUBPROTOCOL}`);
});
const client = new FoxgloveClient({ ws });

function fail(msg) {
  failures.push(msg);
  finish();
}

function finite(v) {
  return typeof v === "number" && Number.isFinite(v);
}

const BYTES_PER_PIXEL = { "32FC1": 4, "16UC1": 2, mono16: 2 };

function checkJointState(m) {
  if (!Array.isArray(m.name) || m.name.length !== 7) return `name has ${m.name && m.name.length} entries, not 7`;
  const p = Array.from(m.position || []);
  if (p.length !== 7) return `position has ${p.length} values, not 7`;
  if (!p.every(finite)) return `position not finite: ${p}`;
  return null;
}

function checkTf(m) {
  if (!Array.isArray(m.transforms) || m.transforms.length === 0) return "no transforms";
  for (const t of m.transforms) {
    if (!t.header.frame_id || !t.child_frame_id) return `a transform without frames: ${JSON.stringify(t.header)}`;
    const { translation: x, rotation: q } = t.transform;
    if (![x.x, x.y, x.z, q.x, q.y, q.z, q.w].every(finite)) return `${t.child_frame_id}: not finite`;
    const n = Math.hypot(q.x, q.y, q.z, q.w);
    if (Math.abs(n - 1) > 1e-6) return `${t.child_frame_id}: quaternion norm ${n}`;
  }
  return null;
}

function checkImage(m) {
  const bpp = BYTES_PER_PIXEL[m.encoding];
  if (!bpp) return `encoding ${m.encoding} is not a depth encoding`;
  const n = m.data.length;
  if (m.width * m.height === 0) return "empty image";
  if (m.width * m.height * bpp !== n) return `${m.width}x${m.height}x${bpp} != ${n} bytes`;
  if (m.step * m.height !== n) return `step ${m.step} * height ${m.height} != ${n} bytes`;
  const view = new DataView(m.data.buffer, m.data.byteOffset, n);
  let valid = 0;
  for (let i = 0; i < n; i += bpp) {
    const d = bpp === 4 ? view.getFloat32(i, !m.is_bigendian) : view.getUint16(i, !m.is_bigendian) / 1000;
    if (Number.isFinite(d) && d > 0) valid++;
  }
  if (valid < (m.width * m.height) / 10) return `only ${valid} valid depth pixels`;
  return null;
}

function checkDescription(m) {
  if (typeof m.data !== "string" || !m.data.includes("<robot")) return "not a URDF";
  const mesh = /filename="(file:\/\/[^"]+)"/.exec(m.data);
  if (!mesh) return "no file:// mesh in the URDF";
  if (!asset.requested) {
    asset = { requested: true, ok: false, uri: mesh[1] };
    client.fetchAsset(mesh[1], 1);
  }
  return null;
}

const CHECKS = {
  "/joint_states": checkJointState,
  "/tf": checkTf,
  "/camera/depth/image_raw": checkImage,
  "/robot_description": checkDescription,
};

/** Channel id → the topic and reader of every wanted channel advertised. */
const advertised = new Map();
client.on("error", (e) => fail(`websocket error: ${e && e.message ? e.message : e}`));
client.on("close", () => {
  if (!done) fail("the server closed the connection");
});
client.on("advertise", (channels) => {
  for (const ch of channels) {
    if (!(ch.topic in WANT)) continue;
    if (ch.encoding !== "cdr" || ch.schemaEncoding !== "ros2msg") {
      fail(`${ch.topic}: advertised as ${ch.encoding}/${ch.schemaEncoding}, not cdr/ros2msg`);
      return;
    }
    let reader;
    try {
      reader = new MessageReader(parse(ch.schema, { ros2: true }));
    } catch (e) {
      fail(`${ch.topic}: schema ${ch.schemaName} does not parse: ${e.message}`);
      return;
    }
    const id = client.subscribe(ch.id);
    subscriptions.set(id, { topic: ch.topic, reader });
    advertised.set(ch.id, { topic: ch.topic, reader });
  }
});
// The foxglove SDK (0.30) sends a channel's advertisement before it records the channel for
// the client: a subscription that arrives in between is refused ("Unknown channel ID: N").
// Subscribe to that channel again.
client.on("status", (status) => {
  const refused = /Unknown channel ID: (\d+)/.exec(status.message || "");
  const sub = refused && advertised.get(Number(refused[1]));
  if (!sub) return;
  setTimeout(() => subscriptions.set(client.subscribe(Number(refused[1])), sub), 100);
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const arrivalMs = performance.timeOrigin + performance.now();
  const sub = subscriptions.get(subscriptionId);
  if (!sub) return;
  let msg;
  try {
    msg = sub.reader.readMessage(data);
  } catch (e) {
    fail(`${sub.topic}: payload of ${data.byteLength} B does not decode: ${e.message}`);
    return;
  }
  const left = data.byteLength - sub.reader.lastReadByteLength();
  if (left > 3) {
    fail(`${sub.topic}: ${left} bytes left after decoding (schema and payload disagree)`);
    return;
  }
  const problem = CHECKS[sub.topic](msg);
  if (problem) {
    fail(`${sub.topic} #${counts[sub.topic] + 1}: ${problem}`);
    return;
  }
  counts[sub.topic]++;
  // A latched message replayed on subscribe carries its original receive time: no latency.
  if (sub.topic !== "/robot_description") latencies[sub.topic].push(arrivalMs - Number(timestamp) / 1e6);
  maybeDone();
});
client.on("fetchAssetResponse", (r) => {
  if (r.status !== 0) {
    fail(`asset ${asset.uri}: ${r.error}`);
    return;
  }
  const want = fs.readFileSync(new URL(asset.uri));
  const got = Buffer.from(r.data.buffer, r.data.byteOffset, r.data.byteLength);
  if (!want.equals(got)) {
    fail(`asset ${asset.uri}: ${got.length} bytes differ from the file (${want.length} bytes)`);
    return;
  }
  asset.ok = true;
  maybeDone();
});

function quantile(sorted, q) {
  if (sorted.length === 0) return null;
  return sorted[Math.min(sorted.length - 1, Math.max(0, Math.ceil(q * sorted.length) - 1))];
}

let passedAt = null;
function maybeDone() {
  if (!asset.ok || !Object.keys(WANT).every((t) => counts[t] >= WANT[t])) return;
  if (passedAt === null) passedAt = Date.now();
  if (Date.now() - passedAt >= measureMs) finish();
}

let done = false;
function finish() {
  if (done) return;
  done = true;
  const stats = {};
  for (const t of Object.keys(WANT)) {
    const s = latencies[t].slice().sort((a, b) => a - b);
    stats[t] = { received: counts[t], latency_median_ms: quantile(s, 0.5), latency_p99_ms: quantile(s, 0.99) };
  }
  stats.seconds = (Date.now() - started) / 1000;
  const report = { ok: failures.length === 0, failures, asset, topics: stats };
  console.log(JSON.stringify(report, null, 2));
  if (statsPath) fs.writeFileSync(statsPath, JSON.stringify(report, null, 2));
  client.close();
  process.exit(failures.length === 0 ? 0 : 1);
}

setTimeout(() => {
  const missing = Object.keys(WANT).filter((t) => counts[t] < WANT[t]).map((t) => `${t} ${counts[t]}/${WANT[t]}`);
  if (!asset.ok) missing.push(`mesh asset ${asset.uri || "(not requested)"}`);
  fail(`timed out after ${timeoutArg} s; missing: ${missing.join(", ")}`);
}, Number(timeoutArg) * 1000);
