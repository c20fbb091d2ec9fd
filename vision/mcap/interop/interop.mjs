// Cross-checks fl_mcap against @mcap/core, the reference TypeScript implementation.
//   node interop.mjs read FILE...   read files written by fl_mcap with McapIndexedReader
//   node interop.mjs write DIR      write theirs_none.mcap and theirs_zstd.mcap with McapWriter
//   node interop.mjs recording FILE... open camera recordings of linectl record (any content)
// The content formulas mirror tests/interop_tool.cpp exactly; keep them in step.

import { open, writeFile } from "node:fs/promises";
import { createRequire } from "node:module";
import path from "node:path";

const require = createRequire(import.meta.url);
const { McapIndexedReader, McapWriter } = require("@mcap/core");
const { loadDecompressHandlers } = require("@mcap/support");
const zstd = require("@foxglove/wasm-zstd");

const MESSAGE_COUNT = 240;
const TOPICS = ["/camera/left/image", "/camera/right/image", "/line/events"];
const START_TIME = 1_700_000_000_000_000_000n;
const FRAME_PERIOD = 33_333_333n;
const CALIBRATION = "camera: left\nfx: 1400.5\n";

const logTime = (i) => START_TIME + BigInt(i) * FRAME_PERIOD;
const payloadSize = (i) => (i % 3 === 2 ? 16 + (i % 7) : 1000 + ((i * 7919) % 9000));
function payload(i) {
  const data = new Uint8Array(payloadSize(i));
  for (let k = 0; k < data.length; k++) data[k] = (i * 131 + k * 7 + (k >> 8)) & 0xff;
  return data;
}
const encoder = new TextEncoder();
const decoder = new TextDecoder();

function fail(message) {
  console.error(`interop.mjs: ${message}`);
  process.exit(1);
}

function equalBytes(a, b) {
  if (a.length !== b.length) return false;
  for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) return false;
  return true;
}

class FileReadable {
  constructor(handle, size) {
    this.handle = handle;
    this.fileSize = size;
  }
  async size() {
    return this.fileSize;
  }
  async read(offset, size) {
    const buffer = new Uint8Array(Number(size));
    const { bytesRead } = await this.handle.read(buffer, 0, buffer.length, Number(offset));
    if (bytesRead !== buffer.length) throw new Error(`short read at ${offset}`);
    return buffer;
  }
}

// Runs `use(reader)` on the file opened with @mcap/core's indexed reader, then closes it.
async function withIndexedReader(file, decompressHandlers, use) {
  const handle = await open(file, "r");
  try {
    const { size } = await handle.stat();
    const reader = await McapIndexedReader.Initialize({
      readable: new FileReadable(handle, BigInt(size)),
      decompressHandlers,
    });
    await use(reader);
  } finally {
    await handle.close();
  }
}

async function readOurs(file, decompressHandlers) {
  await withIndexedReader(file, decompressHandlers, async (reader) => {
    if (reader.chunkIndexes.length < 2) fail(`${file}: expected several chunks`);
    if (reader.header.library !== "fl_mcap") fail(`${file}: library '${reader.header.library}'`);
    let i = 0;
    for await (const message of reader.readMessages({ validateCrcs: true })) {
      const channel = reader.channelsById.get(message.channelId);
      const schema = reader.schemasById.get(channel.schemaId);
      if (
        message.sequence !== i ||
        channel.topic !== TOPICS[i % 3] ||
        message.logTime !== logTime(i) ||
        message.publishTime !== logTime(i) - 1000n ||
        !equalBytes(message.data, payload(i))
      ) {
        fail(`${file}: message ${i} differs`);
      }
      const expectedSchema = i % 3 === 2 ? "fl/LineEvent" : "sensor_msgs/msg/Image";
      if (schema.name !== expectedSchema) fail(`${file}: message ${i} has schema ${schema.name}`);
      i++;
    }
    if (i !== MESSAGE_COUNT) fail(`${file}: ${i} messages, expected ${MESSAGE_COUNT}`);

    let events = 0;
    for await (const message of reader.readMessages({
      topics: [TOPICS[2]],
      startTime: logTime(60),
      endTime: logTime(119),
    })) {
      if (reader.channelsById.get(message.channelId).topic !== TOPICS[2]) fail(`${file}: topic filter`);
      events++;
    }
    if (events !== 20) fail(`${file}: filtered read gave ${events} messages, expected 20`);

    const stats = reader.statistics;
    if (!stats || stats.messageCount !== BigInt(MESSAGE_COUNT) || stats.chunkCount !== reader.chunkIndexes.length) {
      fail(`${file}: statistics ${JSON.stringify(stats, (_, v) => (typeof v === "bigint" ? String(v) : v))}`);
    }
    const attachments = [];
    for await (const attachment of reader.readAttachments({ validateCrcs: true })) attachments.push(attachment);
    if (attachments.length !== 1 || decoder.decode(attachments[0].data) !== CALIBRATION) {
      fail(`${file}: attachment missing or wrong`);
    }
    const metadata = [];
    for await (const record of reader.readMetadata()) metadata.push(record);
    if (metadata.length !== 1 || metadata[0].metadata.get("line_id") !== "fillet-1") {
      fail(`${file}: metadata missing or wrong`);
    }
    const compressions = [...new Set(reader.chunkIndexes.map((index) => index.compression))];
    console.log(
      `@mcap/core read ${path.basename(file)}: ${i} messages in ${reader.chunkIndexes.length} chunks ` +
        `[${compressions.join(",")}], data section CRC ${reader.dataSectionCrc}`,
    );
  });
}

async function writeTheirs(file, compressChunk) {
  const chunks = [];
  let position = 0n;
  const writable = {
    async write(buffer) {
      chunks.push(Buffer.from(buffer));
      position += BigInt(buffer.byteLength);
    },
    position: () => position,
  };
  const writer = new McapWriter({ writable, chunkSize: 32 * 1024, compressChunk });
  await writer.start({ profile: "", library: "@mcap/core interop" });
  const image = await writer.registerSchema({
    name: "sensor_msgs/msg/Image",
    encoding: "ros2msg",
    data: encoder.encode("uint32 height\nuint32 width\nuint8[] data\n"),
  });
  const event = await writer.registerSchema({
    name: "fl/LineEvent",
    encoding: "jsonschema",
    data: encoder.encode('{"type":"object"}'),
  });
  const channels = [
    await writer.registerChannel({ schemaId: image, topic: TOPICS[0], messageEncoding: "cdr", metadata: new Map([["camera", "left"]]) }),
    await writer.registerChannel({ schemaId: image, topic: TOPICS[1], messageEncoding: "cdr", metadata: new Map([["camera", "right"]]) }),
    await writer.registerChannel({ schemaId: event, topic: TOPICS[2], messageEncoding: "json", metadata: new Map() }),
  ];
  await writer.addAttachment({
    logTime: START_TIME,
    createTime: START_TIME - 1n,
    name: "calibration.yaml",
    mediaType: "application/yaml",
    data: encoder.encode(CALIBRATION),
  });
  await writer.addMetadata({ name: "line", metadata: new Map([["line_id", "fillet-1"], ["camera_count", "2"]]) });
  for (let i = 0; i < MESSAGE_COUNT; i++) {
    await writer.addMessage({
      channelId: channels[i % 3],
      sequence: i,
      logTime: logTime(i),
      publishTime: logTime(i) - 1000n,
      data: payload(i),
    });
  }
  await writer.end();
  await writeFile(file, Buffer.concat(chunks));
  console.log(`@mcap/core wrote ${path.basename(file)}`);
}

// The string at `offset` of a little-endian CDR buffer: uint32 length (with the NUL), bytes.
function cdrString(view, bytes, offset) {
  const aligned = (offset + 3) & ~3;
  const length = view.getUint32(aligned, true);
  return { value: decoder.decode(bytes.subarray(aligned + 4, aligned + 4 + length - 1)), next: aligned + 4 + length };
}

// A recording as Foxglove opens it: every record's CRC, every channel with a schema whose
// encoding the tools know, each message counted against the statistics, the attachments, and
// each camera frame a sensor_msgs/msg/CompressedImage whose data is a PNG.
async function readRecording(file, decompressHandlers) {
  await withIndexedReader(file, decompressHandlers, async (reader) => {
    const perChannel = new Map();
    let frames = 0;
    for await (const message of reader.readMessages({ validateCrcs: true })) {
      const channel = reader.channelsById.get(message.channelId);
      const schema = reader.schemasById.get(channel.schemaId);
      if (!schema || !["omgidl", "ros2msg", "jsonschema"].includes(schema.encoding)) {
        fail(`${file}: channel ${channel.topic} has schema encoding '${schema?.encoding}'`);
      }
      perChannel.set(message.channelId, (perChannel.get(message.channelId) ?? 0n) + 1n);
      if (schema.name === "sensor_msgs/msg/CompressedImage") {
        const bytes = message.data;
        const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
        const body = bytes.subarray(4);  // CDR encapsulation header
        const bodyView = new DataView(body.buffer, body.byteOffset, body.byteLength);
        const frameId = cdrString(bodyView, body, 8);  // after stamp (sec, nanosec)
        const format = cdrString(bodyView, body, frameId.next);
        const dataAt = (format.next + 3) & ~3;
        const dataLength = bodyView.getUint32(dataAt, true);
        const png = body.subarray(dataAt + 4, dataAt + 4 + dataLength);
        const signature = [0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a];
        if (view.getUint8(1) !== 1 || format.value !== "png" || !signature.every((b, k) => png[k] === b)) {
          fail(`${file}: ${channel.topic} message ${message.sequence} is not a PNG CompressedImage`);
        }
        frames++;
      }
    }
    const stats = reader.statistics;
    for (const [id, count] of perChannel) {
      if (stats.channelMessageCounts.get(id) !== count) fail(`${file}: channel ${id} count differs from the statistics`);
    }
    const attachments = [];
    for await (const attachment of reader.readAttachments({ validateCrcs: true })) attachments.push(attachment.name);
    if (frames === 0 || attachments.length === 0) fail(`${file}: no frames or no attachments`);
    console.log(
      `@mcap/core opened ${path.basename(file)}: ${stats.messageCount} messages on ${perChannel.size} channels, ` +
        `${frames} PNG frames, attachments ${attachments.join(", ")}`,
    );
  });
}

const [command, ...args] = process.argv.slice(2);
if (command === "read") {
  const handlers = await loadDecompressHandlers();
  for (const file of args) await readOurs(file, handlers);
} else if (command === "write") {
  await zstd.isLoaded;
  await writeTheirs(path.join(args[0], "theirs_none.mcap"), undefined);
  await writeTheirs(path.join(args[0], "theirs_zstd.mcap"), (data) => ({
    compression: "zstd",
    compressedData: zstd.compress(data, 3),
  }));
} else if (command === "recording") {
  const handlers = await loadDecompressHandlers();
  for (const file of args) await readRecording(file, handlers);
} else {
  fail("usage: node interop.mjs read FILE... | write DIR | recording FILE...");
}
