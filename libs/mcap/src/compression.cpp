#include "compression.h"

#include <lz4frame.h>
#include <zstd.h>

#include <algorithm>
#include <stdexcept>

namespace doppel::mcap::compression {

std::string_view name(Compression c) {
  switch (c) {
    case Compression::kZstd:
      return "zstd";
    case Compression::kLz4:
      return "lz4";
    case Compression::kNone:
      break;
  }
  return "";
}

struct Compressor::Contexts {
  ZSTD_CCtx* zstd = nullptr;
  ~Contexts() { ZSTD_freeCCtx(zstd); }
};

Compressor::Compressor(Compression c) : c_(c), contexts_(std::make_unique<Contexts>()) {
  if (c_ == Compression::kZstd) {
    contexts_->zstd = ZSTD_createCCtx();
    if (contexts_->zstd == nullptr) throw std::runtime_error("zstd: cannot create a compression context");
  }
}

Compressor::~Compressor() = default;

void Compressor::compress(std::string_view in, std::string& out) {
  switch (c_) {
    case Compression::kNone:
      out.assign(in);
      return;
    case Compression::kZstd: {
      out.resize(ZSTD_compressBound(in.size()));
      const std::size_t n =
          ZSTD_compressCCtx(contexts_->zstd, out.data(), out.size(), in.data(), in.size(), ZSTD_CLEVEL_DEFAULT);
      if (ZSTD_isError(n)) throw std::runtime_error(std::string("zstd: ") + ZSTD_getErrorName(n));
      out.resize(n);
      return;
    }
    case Compression::kLz4: {
      LZ4F_preferences_t prefs{};
      prefs.frameInfo.contentSize = in.size();  // lets readers size their buffer
      out.resize(LZ4F_compressFrameBound(in.size(), &prefs));
      const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), &prefs);
      if (LZ4F_isError(n)) throw std::runtime_error(std::string("lz4: ") + LZ4F_getErrorName(n));
      out.resize(n);
      return;
    }
  }
}

namespace {

// The next output size: doubles from 64 KiB, never past `limit`.
std::size_t grown(std::size_t current, uint64_t limit) {
  const uint64_t want = std::max<uint64_t>(uint64_t{64} << 10, uint64_t{current} * 2);
  return static_cast<std::size_t>(std::min(want, limit));
}

void size_mismatch(std::string_view what, uint64_t got, uint64_t expected) {
  throw std::runtime_error(std::string(what) + " yields " + (got > expected ? "more than " : "") +
                           std::to_string(got) + " bytes where the chunk says uncompressed_size " +
                           std::to_string(expected));
}

void zstd_decompress(std::string_view in, uint64_t expected, std::string& out) {
  struct Free {
    void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
  };
  std::unique_ptr<ZSTD_DCtx, Free> dctx(ZSTD_createDCtx());
  if (!dctx) throw std::runtime_error("zstd: cannot create a decompression context");
  ZSTD_inBuffer src{in.data(), in.size(), 0};
  std::size_t produced = 0;
  std::size_t last = 1;
  out.clear();
  while (src.pos < src.size) {
    if (produced == out.size()) {
      // Room for one more byte than expected: a stream that makes more is too long.
      if (out.size() > expected) size_mismatch("the zstd stream", out.size(), expected);
      out.resize(grown(out.size(), expected + 1));
    }
    ZSTD_outBuffer dst{out.data(), out.size(), produced};
    const std::size_t before_in = src.pos;
    last = ZSTD_decompressStream(dctx.get(), &dst, &src);
    if (ZSTD_isError(last)) throw std::runtime_error(std::string("corrupt zstd data: ") + ZSTD_getErrorName(last));
    if (dst.pos == produced && src.pos == before_in && dst.pos < dst.size)
      throw std::runtime_error("corrupt zstd data: the stream makes no progress");
    produced = dst.pos;
  }
  // Drain what the decoder still holds once all input is in.
  while (last != 0) {
    if (produced == out.size()) {
      if (out.size() > expected) size_mismatch("the zstd stream", out.size(), expected);
      out.resize(grown(out.size(), expected + 1));
    }
    ZSTD_outBuffer dst{out.data(), out.size(), produced};
    last = ZSTD_decompressStream(dctx.get(), &dst, &src);
    if (ZSTD_isError(last)) throw std::runtime_error(std::string("corrupt zstd data: ") + ZSTD_getErrorName(last));
    if (last != 0 && dst.pos == produced) throw std::runtime_error("truncated zstd data: the frame does not end");
    produced = dst.pos;
  }
  if (produced != expected) size_mismatch("the zstd stream", produced, expected);
  out.resize(produced);
}

void lz4_decompress(std::string_view in, uint64_t expected, std::string& out) {
  struct Free {
    void operator()(LZ4F_dctx* d) const { LZ4F_freeDecompressionContext(d); }
  };
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION)))
    throw std::runtime_error("lz4: cannot create a decompression context");
  std::unique_ptr<LZ4F_dctx, Free> dctx(raw);
  std::size_t consumed = 0;
  std::size_t produced = 0;
  std::size_t hint = 1;
  out.clear();
  while (hint != 0) {
    if (produced == out.size()) {
      if (out.size() > expected) size_mismatch("the lz4 frame", out.size(), expected);
      out.resize(grown(out.size(), expected + 1));
    }
    std::size_t dst_size = out.size() - produced;
    std::size_t src_size = in.size() - consumed;
    hint = LZ4F_decompress(dctx.get(), out.data() + produced, &dst_size, in.data() + consumed, &src_size, nullptr);
    if (LZ4F_isError(hint)) throw std::runtime_error(std::string("corrupt lz4 frame: ") + LZ4F_getErrorName(hint));
    consumed += src_size;
    produced += dst_size;
    if (hint != 0 && src_size == 0 && dst_size == 0)
      throw std::runtime_error(consumed == in.size() ? "truncated lz4 frame: the frame does not end"
                                                     : "corrupt lz4 frame: the stream makes no progress");
  }
  if (consumed != in.size()) throw std::runtime_error("corrupt lz4 chunk: bytes after the end of the lz4 frame");
  if (produced != expected) size_mismatch("the lz4 frame", produced, expected);
  out.resize(produced);
}

}  // namespace

void decompress(std::string_view compression, std::string_view in, uint64_t uncompressed_size, std::string& out) {
  if (uncompressed_size > kMaxUncompressedBytes)
    throw std::runtime_error("chunk uncompressed_size " + std::to_string(uncompressed_size) + " is over the " +
                             std::to_string(kMaxUncompressedBytes) + " bytes this reader accepts");
  if (compression.empty()) {
    if (in.size() != uncompressed_size) size_mismatch("the uncompressed chunk", in.size(), uncompressed_size);
    out.assign(in);
  } else if (compression == "zstd") {
    zstd_decompress(in, uncompressed_size, out);
  } else if (compression == "lz4") {
    lz4_decompress(in, uncompressed_size, out);
  } else {
    std::string shown(compression.substr(0, 40));
    for (char& ch : shown)
      if (static_cast<unsigned char>(ch) < 0x20 || static_cast<unsigned char>(ch) >= 0x7F) ch = '?';
    throw std::runtime_error("unknown chunk compression \"" + shown + "\"");
  }
}

}  // namespace doppel::mcap::compression
