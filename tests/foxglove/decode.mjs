#!/usr/bin/env node
// Decodes MCAP recordings the way Foxglove's MCAP player does, with Foxglove's own packages from npm
// (installed by tests/foxglove/setup.sh), and says whether every message of every channel decodes.
//
//   GRASP_ORIENT_FOXGLOVE_DIR=DIR node tests/foxglove/decode.mjs [--reader auto|indexed|stream]
//                                       [--messages OUT.jsonl] BAG...
//
// The path followed is the one of Foxglove's player (foxglove/studio, packages/studio-base players/
// IterablePlayer/Mcap and packages/mcap-support parseChannel):
// - The file is opened with @mcap/core's McapIndexedReader and the decompressors of @mcap/support
//   (@foxglove/wasm-lz4, @foxglove/wasm-zstd). A file with no chunk index or no channel is read with
//   McapStreamReader instead, as the player falls back to its unindexed source. `--reader` forces one.
// - Each channel with message encoding `cdr` and schema encoding `ros2msg` gets its decoder from
//   @foxglove/rosmsg `parse(schemaText, { ros2: true })` and @foxglove/rosmsg2-serialization
//   `new MessageReader(definitions)`. The player also builds its datatypes map (the first definition under
//   the schema name, the others under their own) and walks it from the root type, which fails on a field
//   type it cannot find: that is checked here too. Any other encoding is a failure: grasp_orient writes
//   none.
// - Every message is decoded with `reader.readMessage(data)`.
//
// Output on stdout: one JSON line per file,
//   {"file", "reader", "profile", "library", "packages": {name: version}, "problems": [...],
//    "channels": [{"id", "topic", "schema", "schemaEncoding", "messageEncoding", "messages", "decoded",
//                  "statistics", "error": null | {"stage": "parse" | "decode", "message", "failures"}}],
//    "ok"}
// where `messages` counts the messages read, `decoded` those that decoded, `statistics` the count in the
// file's Statistics record (null without one). With --messages, every decoded message is also written to
// OUT.jsonl: {"file", "topic", "logTime", "publishTime", "message"}, in the reader's order, in JSON that
// keeps every value: NaN, Infinity, -Infinity and -0.0 as Python's json module reads them, 64-bit
// integers exact, typed arrays as arrays.
// A short summary per file goes to stderr. Exit code: 0 when every message of every channel of every file
// decoded, 1 when anything failed, 2 on bad usage or a missing package.
import { closeSync, openSync, readFileSync, writeSync } from "node:fs";
import { open } from "node:fs/promises";
import { createRequire } from "node:module";
import { join, resolve } from "node:path";

const PACKAGES = ["@mcap/core", "@mcap/support", "@foxglove/rosmsg", "@foxglove/rosmsg2-serialization",
  "@foxglove/wasm-lz4", "@foxglove/wasm-zstd"];
const READ_BYTES = 1 << 20;

function usage(message) {
  process.stderr.write(`decode.mjs: ${message}\n` +
    "usage: GRASP_ORIENT_FOXGLOVE_DIR=DIR node tests/foxglove/decode.mjs [--reader auto|indexed|stream] " +
    "[--messages OUT.jsonl] BAG...\n  (DIR: the last line printed by bash tests/foxglove/setup.sh)\n");
  process.exit(2);
}

function parseArgs(argv) {
  const opts = { reader: "auto", messages: undefined, files: [] };
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    if (a === "--reader" || a === "--messages") {
      if (i + 1 >= argv.length) usage(`${a} needs a value`);
      opts[a.slice(2)] = argv[++i];
    } else if (a.startsWith("--")) {
      usage(`unknown option ${a}`);
    } else {
      opts.files.push(a);
    }
  }
  if (!["auto", "indexed", "stream"].includes(opts.reader)) usage(`--reader ${opts.reader}: not auto, indexed or stream`);
  if (opts.files.length === 0) usage("no file given");
  return opts;
}

// The pinned packages, from the directory tests/foxglove/setup.sh installed them into.
function loadPackages() {
  const dir = process.env.GRASP_ORIENT_FOXGLOVE_DIR;
  if (!dir) usage("GRASP_ORIENT_FOXGLOVE_DIR is not set");
  const req = createRequire(join(resolve(dir), "package.json"));
  const versions = {};
  const mods = {};
  for (const name of PACKAGES) {
    try {
      mods[name] = req(name);
      versions[name] = JSON.parse(readFileSync(join(resolve(dir), "node_modules", name, "package.json"), "utf8")).version;
    } catch (e) {
      usage(`cannot load ${name} from ${dir}/node_modules (${e.message}); run bash tests/foxglove/setup.sh`);
    }
  }
  return { mods, versions };
}

// ---------------------------------------------------------------------------------------------------
// JSON that keeps every decoded value
// ---------------------------------------------------------------------------------------------------
function toJson(v) {
  if (typeof v === "number") {
    if (Number.isNaN(v)) return "NaN";
    if (v === Infinity) return "Infinity";
    if (v === -Infinity) return "-Infinity";
    if (Object.is(v, -0)) return "-0.0";
    return JSON.stringify(v);
  }
  if (typeof v === "bigint") return v.toString();
  if (typeof v === "string" || typeof v === "boolean") return JSON.stringify(v);
  if (v === null || v === undefined) return "null";
  if (Array.isArray(v) || ArrayBuffer.isView(v)) return `[${Array.from(v, toJson).join(",")}]`;
  if (typeof v === "object") {
    return `{${Object.entries(v).map(([k, x]) => `${JSON.stringify(k)}:${toJson(x)}`).join(",")}}`;
  }
  throw new Error(`cannot write a ${typeof v} as JSON`);
}

// ---------------------------------------------------------------------------------------------------
// Decoders, as Foxglove's parseChannel builds them for cdr + ros2msg
// ---------------------------------------------------------------------------------------------------
// The player's datatypes map: the first definition under the schema name, every other under its own.
function datatypesOf(definitions, rootName) {
  const map = new Map();
  definitions.forEach((d, i) => {
    if (i === 0) map.set(rootName, d);
    else if (d.name != undefined) map.set(d.name, d);
  });
  return map;
}

// Walk the datatypes from the root as the player does when it sizes messages: a complex field whose type
// is not in the map fails there.
function walkDatatypes(map, typeName, seen) {
  const def = map.get(typeName);
  if (def == undefined) throw new Error(`Type '${typeName}' not found in definitions`);
  for (const f of def.definitions) {
    if (f.isComplex === true && !seen.includes(f.type)) walkDatatypes(map, f.type, seen.concat(f.type));
  }
}

function makeDecoder(mods, channel, schema) {
  if (channel.messageEncoding !== "cdr") {
    throw new Error(`message encoding '${channel.messageEncoding}', expected 'cdr'`);
  }
  if (schema == undefined || schema.encoding !== "ros2msg") {
    throw new Error(`schema encoding ${schema == undefined ? "(no schema)" : `'${schema.encoding}'`}, expected 'ros2msg'`);
  }
  const text = new TextDecoder().decode(schema.data);
  const definitions = mods["@foxglove/rosmsg"].parse(text, { ros2: true });
  const reader = new mods["@foxglove/rosmsg2-serialization"].MessageReader(definitions);
  walkDatatypes(datatypesOf(definitions, schema.name), schema.name, []);
  return (data) => reader.readMessage(data);
}

// ---------------------------------------------------------------------------------------------------
// One file
// ---------------------------------------------------------------------------------------------------
class FileReadable {
  constructor(handle, size) {
    this.handle = handle;
    this.bytes = size;
  }

  async size() {
    return BigInt(this.bytes);
  }

  async read(offset, length) {
    const out = new Uint8Array(Number(length));
    let done = 0;
    while (done < out.length) {
      const { bytesRead } = await this.handle.read(out, done, out.length - done, Number(offset) + done);
      if (bytesRead === 0) throw new Error(`short read at ${Number(offset) + done} of ${this.bytes} bytes`);
      done += bytesRead;
    }
    return out;
  }
}

class FileCheck {
  constructor(mods, file, sink) {
    this.mods = mods;
    this.file = file;
    this.sink = sink;
    this.channels = new Map(); // id -> {summary, decode}
    this.problems = [];
  }

  addChannel(channel, schema, statistics) {
    const summary = {
      id: channel.id, topic: channel.topic, schema: schema?.name ?? null, schemaEncoding: schema?.encoding ?? null,
      messageEncoding: channel.messageEncoding, messages: 0, decoded: 0, statistics, error: null,
    };
    let decode;
    try {
      decode = makeDecoder(this.mods, channel, schema);
    } catch (e) {
      summary.error = { stage: "parse", message: String(e?.message ?? e), failures: 0 };
    }
    this.channels.set(channel.id, { summary, decode });
  }

  onMessage(message) {
    const ch = this.channels.get(message.channelId);
    if (ch == undefined) {
      this.problems.push(`message on channel ${message.channelId} without prior channel info`);
      return;
    }
    const s = ch.summary;
    s.messages++;
    if (ch.decode == undefined) {
      s.error.failures++;
      return;
    }
    let decoded;
    try {
      decoded = ch.decode(message.data);
    } catch (e) {
      if (s.error == null) s.error = { stage: "decode", message: String(e?.message ?? e), failures: 0 };
      s.error.failures++;
      return;
    }
    s.decoded++;
    if (this.sink != undefined) {
      this.sink(`{"file":${JSON.stringify(this.file)},"topic":${JSON.stringify(s.topic)},` +
        `"logTime":${message.logTime},"publishTime":${message.publishTime},"message":${toJson(decoded)}}\n`);
    }
  }

  async readIndexed(readable, decompressHandlers) {
    const { McapIndexedReader } = this.mods["@mcap/core"];
    const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
    this.header = reader.header;
    for (const channel of reader.channelsById.values()) {
      const schema = reader.schemasById.get(channel.schemaId);
      if (channel.schemaId !== 0 && schema == undefined) {
        this.problems.push(`missing schema ${channel.schemaId} of channel ${channel.id} (${channel.topic})`);
      }
      const count = reader.statistics?.channelMessageCounts.get(channel.id);
      this.addChannel(channel, schema, count == undefined ? null : Number(count));
    }
    for await (const message of reader.readMessages({ validateCrcs: false })) this.onMessage(message);
  }

  async readStream(handle, size, decompressHandlers) {
    const { McapStreamReader } = this.mods["@mcap/core"];
    const reader = new McapStreamReader({ decompressHandlers });
    const schemas = new Map();
    const buf = new Uint8Array(READ_BYTES);
    let statistics;
    for (let pos = 0; ;) {
      const { bytesRead } = await handle.read(buf, 0, buf.length, pos);
      if (bytesRead > 0) reader.append(buf.slice(0, bytesRead));
      pos += bytesRead;
      for (let rec; (rec = reader.nextRecord()) != undefined;) {
        if (rec.type === "Header") this.header = rec;
        else if (rec.type === "Schema") schemas.set(rec.id, rec);
        else if (rec.type === "Channel" && !this.channels.has(rec.id)) {
          if (rec.schemaId !== 0 && !schemas.has(rec.schemaId)) {
            this.problems.push(`channel ${rec.id} (${rec.topic}) before its schema ${rec.schemaId}`);
          }
          this.addChannel(rec, schemas.get(rec.schemaId), null);
        } else if (rec.type === "Message") this.onMessage(rec);
        else if (rec.type === "Statistics") statistics = rec;
      }
      if (bytesRead === 0 || pos >= size) break;
    }
    if (!reader.done()) this.problems.push(`the stream ends before the MCAP footer (${size} bytes)`);
    for (const { summary } of this.channels.values()) {
      const n = statistics?.channelMessageCounts.get(summary.id);
      summary.statistics = n == undefined ? null : Number(n);
    }
  }

  // Foxglove's player reads indexed when the file has a chunk index and channels, else as a stream.
  async run(mode, decompressHandlers) {
    const handle = await open(this.file, "r");
    try {
      const { size } = await handle.stat();
      let how = mode;
      if (mode !== "stream") {
        const { McapIndexedReader } = this.mods["@mcap/core"];
        let indexable = false;
        try {
          const probe = await McapIndexedReader.Initialize({ readable: new FileReadable(handle, size), decompressHandlers });
          indexable = probe.chunkIndexes.length > 0 && probe.channelsById.size > 0;
        } catch (e) {
          if (mode === "indexed") throw e;
        }
        if (mode === "indexed" && !indexable) throw new Error("no chunk index or no channel: cannot read indexed");
        how = indexable ? "indexed" : "stream";
      }
      this.reader = how;
      if (how === "indexed") await this.readIndexed(new FileReadable(handle, size), decompressHandlers);
      else await this.readStream(handle, size, decompressHandlers);
    } finally {
      await handle.close();
    }
  }

  result(versions) {
    const channels = [...this.channels.values()].map((c) => c.summary).sort((a, b) => a.id - b.id);
    const ok = this.problems.length === 0 && channels.length > 0 && channels.every((c) =>
      c.error == null && c.decoded === c.messages && (c.statistics == null || c.statistics === c.messages));
    return {
      file: this.file, reader: this.reader ?? null, profile: this.header?.profile ?? null,
      library: this.header?.library ?? null, packages: versions, problems: this.problems, channels, ok,
    };
  }
}

function describe(r) {
  const lines = [`${r.file}: ${r.ok ? "ok" : "FAILED"} (${r.reader == null ? "not read" : `${r.reader} reader`})`];
  for (const p of r.problems) lines.push(`  problem: ${p}`);
  for (const c of r.channels) {
    const err = c.error == null ? "" : ` — ${c.error.stage} error on ${c.error.failures} messages: ${c.error.message}`;
    lines.push(`  ${c.topic} [${c.schema}]: ${c.decoded}/${c.messages} decoded` +
      `${c.statistics == null ? "" : `, ${c.statistics} in statistics`}${err}`);
  }
  if (r.channels.length === 0) lines.push("  no channel");
  return lines.join("\n") + "\n";
}

async function main() {
  const opts = parseArgs(process.argv.slice(2));
  const { mods, versions } = loadPackages();
  const decompressHandlers = await mods["@mcap/support"].loadDecompressHandlers();
  const out = opts.messages == undefined ? undefined : openSync(opts.messages, "w");
  const sink = out == undefined ? undefined : (line) => writeSync(out, line);
  let failed = false;
  try {
    for (const file of opts.files) {
      const check = new FileCheck(mods, file, sink);
      try {
        await check.run(opts.reader, decompressHandlers);
      } catch (e) {
        check.problems.push(`cannot read: ${e?.message ?? e}`);
      }
      const r = check.result(versions);
      failed ||= !r.ok;
      process.stdout.write(JSON.stringify(r) + "\n");
      process.stderr.write(describe(r));
    }
  } finally {
    if (out != undefined) closeSync(out);
  }
  process.exitCode = failed ? 1 : 0;
}

await main();
