#!/usr/bin/python3
"""Writes the seed corpus of mcap_reader_fuzz: small MCAP files built record by record from the
specification (https://mcap.dev/spec), not with Doppel's writer, so they also stand for files other
writers make: messages outside chunks, schemas and channels inside chunks, unindexed chunks,
attachments, private records, a file cut off by a kill, and a few broken ones.

Each file is named <what>.<messages>.mcap (the number of messages a reader returns) or
<what>.bad.mcap (a reader must refuse it); tests/mcap/mcap_python_test.cpp checks that.

Usage: fuzz/make_mcap_corpus.py [fuzz/corpus/mcap_reader_fuzz]   (python3-zstandard, python3-lz4)
"""
import os
import struct
import sys
import zlib

import lz4.frame
import zstandard

MAGIC = b"\x89MCAP0\r\n"


def u16(v):
    return struct.pack("<H", v)


def u32(v):
    return struct.pack("<I", v)


def u64(v):
    return struct.pack("<Q", v)


def string(s):
    b = s.encode() if isinstance(s, str) else s
    return u32(len(b)) + b


def string_map(m):
    body = b"".join(string(k) + string(v) for k, v in sorted(m.items()))
    return u32(len(body)) + body


def record(op, content):
    return bytes([op]) + u64(len(content)) + content


def header(profile="", library="corpus"):
    return record(0x01, string(profile) + string(library))


def schema(sid, name="corpus.Msg", encoding="protobuf", data=b"\x0a\x00"):
    return record(0x03, u16(sid) + string(name) + string(encoding) + u32(len(data)) + data)


def channel(cid, sid, topic, encoding="protobuf", metadata=None):
    return record(0x04, u16(cid) + u16(sid) + string(topic) + string(encoding) + string_map(metadata or {}))


def message(cid, seq, t, data=b"payload"):
    return record(0x05, u16(cid) + u32(seq) + u64(t) + u64(t) + data)


def chunk(inner, times, compression="zstd", crc=True):
    if compression == "zstd":
        payload = zstandard.ZstdCompressor().compress(inner)
    elif compression == "lz4":
        payload = lz4.frame.compress(inner)
    else:
        payload = inner
    return record(0x06, u64(min(times)) + u64(max(times)) + u64(len(inner)) + u32(zlib.crc32(inner) if crc else 0) +
                  string(compression) + u64(len(payload)) + payload)


def footer(summary_start=0, summary_offset_start=0, crc=0):
    return record(0x02, u64(summary_start) + u64(summary_offset_start) + u32(crc))


def data_end(data, crc=True):
    return record(0x0F, u32(zlib.crc32(data) if crc else 0))


def indexed_file(compression, chunks=3, per_chunk=4, marks=None):
    """Chunks with message indexes, Data End, a summary (schemas, channels, statistics, chunk
    indexes), summary offsets and a footer with its CRC. `marks` gets the offsets of the first
    message index and of the summary."""
    out = MAGIC + header("corpus")
    chunk_indexes = []
    t = 100
    for c in range(chunks):
        inner = (schema(1) + channel(1, 1, "/a")) if c == 0 else b""
        index = []
        times = []
        for i in range(per_chunk):
            index.append((t, len(inner)))
            inner += message(1, t, t, bytes([c, i]) * 5)
            times.append(t)
            t += 10 if i % 2 else -3  # out of order inside the chunk
        start = len(out)
        out += chunk(inner, times, compression)
        length = len(out) - start
        offsets_at = len(out)
        if marks is not None:
            marks.setdefault("first_message_index", offsets_at)
        body = b"".join(u64(ts) + u64(off) for ts, off in index)
        out += record(0x07, u16(1) + u32(len(body)) + body)
        chunk_indexes.append(record(0x08, u64(min(times)) + u64(max(times)) + u64(start) + u64(length) +
                                    u32(10) + u16(1) + u64(offsets_at) + u64(len(out) - offsets_at) +
                                    string(compression) + u64(0) + u64(len(inner))))
    out += data_end(out)
    summary_start = len(out)
    if marks is not None:
        marks["summary"] = summary_start
    groups = [(0x03, schema(1)), (0x04, channel(1, 1, "/a")),
              (0x0B, record(0x0B, u64(chunks * per_chunk) + u16(1) + u32(1) + u32(0) + u32(0) + u32(chunks) +
                            u64(97) + u64(t) + u32(10) + u16(1) + u64(chunks * per_chunk))),
              (0x08, b"".join(chunk_indexes))]
    offsets = b""
    for op, body in groups:
        offsets += record(0x0E, bytes([op]) + u64(len(out)) + u64(len(body)))
        out += body
    summary_offset_start = len(out)
    out += offsets
    tail = bytes([0x02]) + u64(20) + u64(summary_start) + u64(summary_offset_start)
    crc = zlib.crc32(out[summary_start:] + tail)
    return out + tail + u32(crc) + MAGIC


def files():
    loose = MAGIC + header() + schema(1) + channel(1, 1, "/loose") + message(1, 0, 30) + message(1, 1, 10) + \
        message(1, 2, 20)
    yield "empty.0", MAGIC + header() + footer() + MAGIC
    yield "loose.3", loose + data_end(loose) + footer() + MAGIC
    for compression in ("zstd", "lz4", ""):
        yield f"indexed_{compression or 'none'}.12", indexed_file(compression)
    inner = schema(2, "corpus.B") + channel(5, 2, "/b", "cdr", {"qos": "reliable"}) + message(5, 1, 7) + \
        record(0x90, b"private inside a chunk") + message(5, 2, 3)
    unindexed = MAGIC + header() + chunk(inner, [3, 7], "lz4") + record(0x09, u64(1) + u64(0) + string("a.txt") +
                                                                       string("text/plain") + u64(2) + b"hi" + u32(0))
    unindexed += chunk(message(5, 3, 1), [1], "", crc=False) + record(0x80, b"private") + message(5, 4, 0)
    yield "unindexed.4", unindexed + data_end(unindexed, crc=False) + footer() + MAGIC
    marks = {}
    full = indexed_file("zstd", marks=marks)
    yield "killed.4", full[:marks["first_message_index"] + 30]  # cut in the message index after chunk 1
    yield "killed_in_summary.12", full[:marks["summary"] + 20]
    yield "no_magic.bad", b"\x89MCAP1\r\n" + full[8:]
    bad_crc = bytearray(indexed_file(""))
    bad_crc[bad_crc.index(b"/a") + 40] ^= 0x01  # a payload byte inside the first (stored) chunk
    yield "chunk_crc.bad", bytes(bad_crc)
    huge = MAGIC + header() + bytes([0x05]) + u64(1 << 62) + b"short"
    yield "huge_length.bad", huge + footer() + MAGIC
    bad_zstd = MAGIC + header() + record(0x06, u64(0) + u64(0) + u64(100) + u32(0) + string("zstd") + u64(8) +
                                         b"\x28\xb5\x2f\xfdgarb")
    yield "bad_zstd.bad", bad_zstd + footer() + MAGIC
    yield "unknown_compression.bad", MAGIC + header() + chunk(message(1, 0, 0), [0], "brotli") + footer() + MAGIC


def main():
    out_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "corpus", "mcap_reader_fuzz")
    os.makedirs(out_dir, exist_ok=True)
    for name, data in files():
        with open(os.path.join(out_dir, name + ".mcap"), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    main()
