// An independent Foxglove WebSocket client (npm @foxglove/ws-protocol over ws), for the test suite:
//   node client.mjs ws://127.0.0.1:8765 TOPIC[,TOPIC...] COUNT [SECONDS]
// Prints one JSON line per event: {"advertised": [{topic, schemaName, encoding}]} for each advertisement,
// {"topic", "logTime", "json"} for each of COUNT messages of each listed topic whose encoding is
// json (its payload parsed) or {"topic", "logTime", "bytes"} for others; exits 0 when every topic
// gave COUNT messages, 1 on an error or after SECONDS (default 20) without them.
import protocol from "@foxglove/ws-protocol";
import { WebSocket } from "ws";

const { FoxgloveClient } = protocol;

const [url, topicList, countText, secondsText] = process.argv.slice(2);
const topics = topicList.split(",");
const count = Number(countText);
const seconds = Number(secondsText ?? "20");
const got = Object.fromEntries(topics.map((t) => [t, 0]));
const channels = new Map(); // channel id -> channel
const subscriptions = new Map(); // subscription id -> channel

// foxglove-sdk's server speaks the subprotocol foxglove.sdk.v1 (and refuses the client's default)
const client = new FoxgloveClient({ ws: new WebSocket(url, ["foxglove.sdk.v1"]) });
const give_up = setTimeout(() => {
  console.log(JSON.stringify({ timeout: got }));
  process.exit(1);
}, seconds * 1000);
client.on("error", (error) => {
  console.log(JSON.stringify({ error: String(error) }));
  process.exit(1);
});
client.on("advertise", (advertised) => {
  console.log(JSON.stringify({ advertised: advertised.map((c) => ({ topic: c.topic, schemaName: c.schemaName, encoding: c.encoding })) }));
  for (const c of advertised) {
    channels.set(c.id, c);
    if (topics.includes(c.topic)) subscriptions.set(client.subscribe(c.id), c);
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const c = subscriptions.get(subscriptionId);
  if (!c || got[c.topic] >= count) return;
  got[c.topic] += 1;
  const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  const body = c.encoding === "json" ? { json: JSON.parse(new TextDecoder().decode(bytes)) } : { bytes: bytes.length };
  console.log(JSON.stringify({ topic: c.topic, logTime: String(timestamp), ...body }));
  if (topics.every((t) => got[t] >= count)) {
    clearTimeout(give_up);
    client.close();
    process.exit(0);
  }
});
