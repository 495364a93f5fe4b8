#!/usr/bin/python3
"""An MCAP reader written from the specification (https://mcap.dev/spec), independent of Doppel's
C++ reader: it checks what doppel::mcap::Writer writes, and the recording tests decode recordings
with it. Standard library, python3-zstandard, python3-lz4 and python3-protobuf only (no mcap package).

It parses every record of the file, checks the data section, summary and chunk CRCs (when not 0),
decompresses chunks (zstd, lz4 frame, none) and prints JSON: the header, whether the file is complete
(footer and closing magic) or where it stops, statistics, metadata and per channel its topic, schema
name, message count, first/last log time and the (log_time, sequence) of each message in log-time
order. A file without a footer is read up to its last complete record, as a killed writer leaves it.

Usage: mcap_read.py FILE [--payloads] [--decode TOPIC ...]
  --payloads      add each message's publish time and payload (hex) to its channel's list
  --decode TOPIC  decode the protobuf messages of TOPIC with its schema's FileDescriptorSet
                  (output "decoded": {TOPIC: [{"log_time": t, "message": {...}}, ...]})
Exit status 0 when the file parses (complete or a readable prefix), 1 on a bad file (message on stderr).
"""
import argparse
import json
import struct
import sys
import zlib

MAGIC = b"\x89MCAP0\r\n"
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
OP_MESSAGE_INDEX, OP_CHUNK_INDEX, OP_ATTACHMENT, OP_ATTACHMENT_INDEX = 0x07, 0x08, 0x09, 0x0A
OP_STATISTICS, OP_METADATA, OP_METADATA_INDEX, OP_SUMMARY_OFFSET, OP_DATA_END = 0x0B, 0x0C, 0x0D, 0x0E, 0x0F


class BadFile(Exception):
    pass


class Fields:
    """Reads a record's fields in order, little-endian, checking each against the record's end."""

    def __init__(self, data, where):
        self.data, self.pos, self.where = data, 0, where

    def take(self, n, what):
        if n > len(self.data) - self.pos:
            raise BadFile(f"{self.where}: {what} runs past the end of the record")
        out = self.data[self.pos:self.pos + n]
        self.pos += n
        return out

    def u8(self, what):
        return self.take(1, what)[0]

    def u16(self, what):
        return struct.unpack("<H", self.take(2, what))[0]

    def u32(self, what):
        return struct.unpack("<I", self.take(4, what))[0]

    def u64(self, what):
        return struct.unpack("<Q", self.take(8, what))[0]

    def string(self, what):
        return self.take(self.u32(what), what).decode("utf-8")

    def prefixed_bytes(self, what):
        return self.take(self.u32(what), what)

    def string_map(self, what):
        body = Fields(self.take(self.u32(what), what), self.where)
        out = {}
        while body.pos < len(body.data):
            key = body.string(what)
            out[key] = body.string(what)
        return out

    def u16_u64_map(self, what):
        body = Fields(self.take(self.u32(what), what), self.where)
        out = {}
        while body.pos < len(body.data):
            key = body.u16(what)
            out[key] = body.u64(what)
        return out

    def rest(self):
        return self.take(len(self.data) - self.pos, "data")


def records(data, start, end, where):
    """Yields (offset, opcode, content) for the records in data[start:end]; a record cut off by
    `end` is yielded as (offset, opcode, None)."""
    pos = start
    while pos < end:
        if end - pos < 9:
            yield pos, None, None
            return
        op = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        if length > end - pos - 9:
            yield pos, op, None
            return
        yield pos, op, data[pos + 9:pos + 9 + length]
        pos += 9 + length


def decompress(compression, payload, size, where):
    if compression == "":
        out = payload
    elif compression == "zstd":
        import zstandard
        out = zstandard.ZstdDecompressor().decompressobj().decompress(payload)
    elif compression == "lz4":
        import lz4.frame
        out = lz4.frame.decompress(payload)
    else:
        raise BadFile(f"{where}: unknown compression {compression!r}")
    if len(out) != size:
        raise BadFile(f"{where}: decompressed to {len(out)} bytes, the chunk says {size}")
    return out


class McapFile:
    def __init__(self, path):
        with open(path, "rb") as f:
            self.data = data = f.read()
        self.path = path
        self.schemas, self.channels, self.messages, self.metadata = {}, {}, [], []
        self.statistics, self.chunk_count, self.complete, self.stop = None, 0, False, ""
        self.summary_schemas, self.summary_channels, self.chunk_indexes = {}, {}, []
        if data[:8] != MAGIC:
            raise BadFile(f"{path}: no MCAP magic at the start")
        recs = records(data, 8, len(data), path)
        pos, op, content = next(recs, (8, None, None))
        if op != OP_HEADER or content is None:
            raise BadFile(f"{path}: byte 8: the first record is not a whole Header")
        header = Fields(content, f"{path}: Header")
        self.profile, self.library = header.string("profile"), header.string("library")
        data_start = 8 + 9 + len(content)

        footer_at = len(data) - 8 - 29
        if footer_at >= data_start and data[-8:] == MAGIC and data[footer_at] == OP_FOOTER:
            footer = Fields(data[footer_at + 9:footer_at + 29], f"{path}: Footer")
            (length,) = struct.unpack_from("<Q", data, footer_at + 1)
            if length == 20:
                self.complete = True
                self.summary_start = footer.u64("summary_start")
                self.summary_offset_start = footer.u64("summary_offset_start")
                self.summary_crc = footer.u32("summary_crc")
        if self.complete:
            data_end = self.summary_start or self.summary_offset_start or footer_at
            self.read_summary(footer_at)
        else:
            data_end = len(data)
        self.read_data(data_start, data_end)

    def read_summary(self, footer_at):
        path, data = self.path, self.data
        if self.summary_start == 0:
            return
        if self.summary_crc != 0:
            crc = zlib.crc32(data[self.summary_start:footer_at + 9 + 16])
            if crc != self.summary_crc:
                raise BadFile(f"{path}: summary CRC {crc:#x}, the footer says {self.summary_crc:#x}")
        end = self.summary_offset_start or footer_at
        opcodes_seen = []
        for pos, op, content in records(data, self.summary_start, end, path):
            if content is None:
                raise BadFile(f"{path}: byte {pos}: summary record cut off")
            if not opcodes_seen or opcodes_seen[-1] != op:
                if op in opcodes_seen:
                    raise BadFile(f"{path}: byte {pos}: summary records not grouped by opcode")
                opcodes_seen.append(op)
            where = f"{path}: byte {pos}"
            if op == OP_SCHEMA:
                s = self.parse_schema(content, where)
                self.summary_schemas[s["id"]] = s
            elif op == OP_CHANNEL:
                c = self.parse_channel(content, where)
                self.summary_channels[c["id"]] = c
            elif op == OP_CHUNK_INDEX:
                f = Fields(content, where)
                self.chunk_indexes.append({
                    "message_start_time": f.u64("message_start_time"), "message_end_time": f.u64("message_end_time"),
                    "chunk_start_offset": f.u64("chunk_start_offset"), "chunk_length": f.u64("chunk_length"),
                    "message_index_offsets": f.u16_u64_map("message_index_offsets"),
                    "message_index_length": f.u64("message_index_length"), "compression": f.string("compression"),
                    "compressed_size": f.u64("compressed_size"), "uncompressed_size": f.u64("uncompressed_size")})
            elif op == OP_STATISTICS:
                f = Fields(content, where)
                self.statistics = {
                    "message_count": f.u64("message_count"), "schema_count": f.u16("schema_count"),
                    "channel_count": f.u32("channel_count"), "attachment_count": f.u32("attachment_count"),
                    "metadata_count": f.u32("metadata_count"), "chunk_count": f.u32("chunk_count"),
                    "message_start_time": f.u64("message_start_time"), "message_end_time": f.u64("message_end_time"),
                    "channel_message_counts": {str(k): v for k, v in f.u16_u64_map("channel_message_counts").items()}}
            elif op == OP_METADATA_INDEX:
                f = Fields(content, where)
                offset, length, name = f.u64("offset"), f.u64("length"), f.string("name")
                if self.data[offset] != OP_METADATA or offset + length > len(self.data):
                    raise BadFile(f"{where}: the Metadata Index points at no Metadata record")
        if self.summary_offset_start:
            for pos, op, content in records(data, self.summary_offset_start, footer_at, path):
                if content is None or op != OP_SUMMARY_OFFSET:
                    raise BadFile(f"{path}: byte {pos}: not a whole Summary Offset record")
                f = Fields(content, f"{path}: byte {pos}")
                group_op, start, length = f.u8("group_opcode"), f.u64("group_start"), f.u64("group_length")
                first = data[start] if start < len(data) else None
                if first != group_op or start + length > self.summary_offset_start:
                    raise BadFile(f"{path}: byte {pos}: Summary Offset for opcode {group_op:#x} points elsewhere")

    def parse_schema(self, content, where):
        f = Fields(content, where)
        return {"id": f.u16("id"), "name": f.string("name"), "encoding": f.string("encoding"),
                "data": f.prefixed_bytes("data")}

    def parse_channel(self, content, where):
        f = Fields(content, where)
        return {"id": f.u16("id"), "schema_id": f.u16("schema_id"), "topic": f.string("topic"),
                "message_encoding": f.string("message_encoding"), "metadata": f.string_map("metadata")}

    def add_record(self, op, content, where, order):
        if op == OP_SCHEMA:
            s = self.parse_schema(content, where)
            if s["id"] != 0:
                self.schemas.setdefault(s["id"], s)
        elif op == OP_CHANNEL:
            c = self.parse_channel(content, where)
            self.channels.setdefault(c["id"], c)
        elif op == OP_MESSAGE:
            f = Fields(content, where)
            channel, sequence, log_time, publish_time = f.u16("channel_id"), f.u32("sequence"), f.u64("log_time"), \
                f.u64("publish_time")
            if channel not in self.channels:
                raise BadFile(f"{where}: message on channel {channel} before its Channel record")
            self.messages.append((log_time, order, channel, sequence, publish_time, f.rest()))

    def read_data(self, start, end):
        path, data = self.path, self.data
        order = 0
        last_chunk_end = None
        for pos, op, content in records(data, start, end, path):
            where = f"{path}: byte {pos}"
            if content is None:
                if self.complete:
                    raise BadFile(f"{where}: record runs past the end of the data section")
                self.stop = f"record cut off at byte {pos}"
                return
            if op == OP_CHUNK:
                f = Fields(content, where)
                start_time, end_time = f.u64("message_start_time"), f.u64("message_end_time")
                size, crc, compression = f.u64("uncompressed_size"), f.u32("uncompressed_crc"), f.string("compression")
                payload = f.take(f.u64("records length"), "records")
                inner = decompress(compression, payload, size, where)
                if crc != 0 and zlib.crc32(inner) != crc:
                    raise BadFile(f"{where}: chunk CRC {zlib.crc32(inner):#x}, the chunk says {crc:#x}")
                first_message = len(self.messages)
                for ipos, iop, icontent in records(inner, 0, len(inner), where):
                    if icontent is None:
                        raise BadFile(f"{where}: record cut off inside the chunk at {ipos}")
                    order += 1
                    self.add_record(iop, icontent, f"{where} (chunk offset {ipos})", order)
                times = [m[0] for m in self.messages[first_message:]]
                if times and (min(times) != start_time or max(times) != end_time):
                    raise BadFile(f"{where}: chunk says times {start_time}..{end_time}, its messages "
                                  f"{min(times)}..{max(times)}")
                self.chunk_count += 1
                last_chunk_end = pos + 9 + len(content)
            elif op == OP_MESSAGE_INDEX:
                f = Fields(content, where)
                f.u16("channel_id")
                body = f.prefixed_bytes("records")
                if len(body) % 16 != 0:
                    raise BadFile(f"{where}: Message Index records not a whole number of (time, offset)")
                if last_chunk_end is None:
                    raise BadFile(f"{where}: Message Index before any chunk")
            elif op == OP_DATA_END:
                (expected,) = struct.unpack_from("<I", content, 0)
                if expected != 0 and zlib.crc32(data[:pos]) != expected:
                    raise BadFile(f"{where}: data section CRC {zlib.crc32(data[:pos]):#x}, Data End says {expected:#x}")
                if not self.complete:
                    self.stop = f"data section ends at byte {pos + 9 + len(content)}, no footer"
                return
            elif op == OP_METADATA:
                f = Fields(content, where)
                self.metadata.append({"name": f.string("name"), "metadata": f.string_map("metadata")})
            else:
                order += 1
                self.add_record(op, content, where, order)
        if not self.complete:
            self.stop = self.stop or f"file ends at byte {len(data)} after a whole record"


def decode_topic(mcap, topic):
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
    from google.protobuf.json_format import MessageToDict
    channels = [c for c in mcap.channels.values() if c["topic"] == topic]
    if not channels:
        raise BadFile(f"{mcap.path}: no channel with topic {topic!r}")
    out = []
    for channel in channels:
        schema = mcap.schemas.get(channel["schema_id"])
        if schema is None or schema["encoding"] != "protobuf":
            raise BadFile(f"{mcap.path}: topic {topic!r} has no protobuf schema")
        pool = descriptor_pool.DescriptorPool()
        for file in descriptor_pb2.FileDescriptorSet.FromString(schema["data"]).file:
            pool.Add(file)
        descriptor = pool.FindMessageTypeByName(schema["name"])
        if hasattr(message_factory, "GetMessageClass"):
            cls = message_factory.GetMessageClass(descriptor)
        else:
            cls = message_factory.MessageFactory(pool).GetPrototype(descriptor)
        for m in sorted(mcap.messages, key=lambda m: (m[0], m[1])):
            if m[2] == channel["id"]:
                out.append({"log_time": m[0], "message": MessageToDict(cls.FromString(m[5]))})
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("file")
    parser.add_argument("--payloads", action="store_true")
    parser.add_argument("--decode", action="append", default=[], metavar="TOPIC")
    args = parser.parse_args()
    try:
        mcap = McapFile(args.file)
        result = {
            "profile": mcap.profile, "library": mcap.library, "complete": mcap.complete, "stop": mcap.stop,
            "chunk_count": mcap.chunk_count, "message_count": len(mcap.messages), "statistics": mcap.statistics,
            "chunk_index_count": len(mcap.chunk_indexes), "metadata": mcap.metadata, "channels": {}}
        if mcap.chunk_indexes:  # spec: indexed chunks' channels must be in the summary
            for cid, c in mcap.channels.items():
                if cid not in mcap.summary_channels:
                    raise BadFile(f"{args.file}: channel {cid} is not in the summary")
        ordered = sorted(mcap.messages, key=lambda m: (m[0], m[1]))
        for cid, c in sorted(mcap.channels.items()):
            schema = mcap.schemas.get(c["schema_id"])
            mine = [m for m in ordered if m[2] == cid]
            entry = {"topic": c["topic"], "schema": schema["name"] if schema else "",
                     "schema_encoding": schema["encoding"] if schema else "",
                     "message_encoding": c["message_encoding"], "metadata": c["metadata"], "count": len(mine),
                     "first_log_time": mine[0][0] if mine else None, "last_log_time": mine[-1][0] if mine else None,
                     "messages": [[m[0], m[3]] + ([m[4], m[5].hex()] if args.payloads else []) for m in mine]}
            result["channels"][str(cid)] = entry
        if args.decode:
            result["decoded"] = {topic: decode_topic(mcap, topic) for topic in args.decode}
    except (BadFile, UnicodeDecodeError, struct.error, RuntimeError, ValueError) as e:
        print(f"mcap_read.py: {e}", file=sys.stderr)
        return 1
    json.dump(result, sys.stdout, indent=1)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
