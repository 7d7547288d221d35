/// @file grainlight/core/serialization.hpp
/// The one small container format shared by every precomputed data file of grainlight (packing
/// tiles, scatterometer results, bulk tables, shell tables, multiple-scattering tables), plus
/// little-endian byte readers/writers and an atomic file writer.
///
/// ## Container format (version 1)
///
/// All integers are little-endian; floating-point values are IEEE-754 binary64 (or binary32 where
/// a payload says so), little-endian. A file is a fixed 48-byte header followed by the payload:
///
/// | offset | size | field            | meaning                                                   |
/// | ------ | ---- | ---------------- | --------------------------------------------------------- |
/// | 0      | 8    | magic            | the bytes `G R N L I G H T`                               |
/// | 8      | 4    | container_version| container layout version (this header), currently 1       |
/// | 12     | 4    | kind             | four-character code of the payload type, e.g. `TILE`      |
/// | 16     | 4    | kind_version     | version of that payload's layout                          |
/// | 20     | 4    | reserved         | 0                                                         |
/// | 24     | 8    | payload_size     | number of payload bytes that follow the header            |
/// | 32     | 8    | payload_checksum | FNV-1a 64-bit hash of the payload bytes                   |
/// | 40     | 8    | header_checksum  | FNV-1a 64-bit hash of header bytes [0, 40)                |
///
/// The file size must be exactly 48 + payload_size. A reader checks, in this order: the file is
/// at least 48 bytes, the magic, the header checksum, the container version, the kind and kind
/// version it expects, payload_size == file size - 48 (so a hostile header can never make the
/// reader allocate more than the file holds), and the payload checksum. Any failure throws
/// grainlight::format_error naming the file and the problem. Payload parsers then use
/// ByteReader, which throws format_error on any read past the end, and must check element counts
/// against the remaining bytes before allocating.
///
/// Writers build the payload in memory and call write_container_atomic, which writes a temporary
/// file next to the target and renames it over the target, so an interrupted write never leaves
/// a half-written file under the final name.
#pragma once

#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <vector>

#include "grainlight/core/error.hpp"

namespace grainlight {

static_assert(std::endian::native == std::endian::little,
              "grainlight's container format is little-endian; big-endian hosts need byte swapping here");

/// Magic bytes at the start of every grainlight container file.
inline constexpr std::array<char, 8> container_magic{'G', 'R', 'N', 'L', 'I', 'G', 'H', 'T'};
/// Layout version of the container header described in this file.
inline constexpr std::uint32_t container_version = 1;
/// Size of the container header in bytes.
inline constexpr std::size_t container_header_size = 48;

/// Four-character code as a little-endian 32-bit integer ("TILE" -> 'T' in the lowest byte).
[[nodiscard]] constexpr std::uint32_t fourcc(const char (&s)[5]) noexcept {
    return std::uint32_t(std::uint8_t(s[0])) | (std::uint32_t(std::uint8_t(s[1])) << 8) |
           (std::uint32_t(std::uint8_t(s[2])) << 16) | (std::uint32_t(std::uint8_t(s[3])) << 24);
}

/// FNV-1a 64-bit hash (Fowler, Noll, Vo) of `size` bytes, continuing from `h` (default: the
/// standard offset basis). Used as the container's corruption check, not as a cryptographic hash.
[[nodiscard]] inline std::uint64_t fnv1a64(const void* data, std::size_t size,
                                           std::uint64_t h = 0xcbf29ce484222325ull) noexcept {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

/// Appends trivially copyable values (little-endian host layout) to a growing byte buffer.
class ByteWriter {
public:
    /// Append one value (its in-memory, little-endian bytes).
    template <class T>
    ByteWriter& put(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        const auto old = bytes_.size();
        bytes_.resize(old + sizeof(T));
        std::memcpy(bytes_.data() + old, &v, sizeof(T));
        return *this;
    }
    /// Append `n` elements of a trivially copyable type.
    template <class T>
    ByteWriter& put_array(const T* v, std::size_t n) {
        static_assert(std::is_trivially_copyable_v<T>);
        const auto old = bytes_.size();
        bytes_.resize(old + n * sizeof(T));
        if (n) std::memcpy(bytes_.data() + old, v, n * sizeof(T));
        return *this;
    }
    /// The bytes written so far.
    [[nodiscard]] const std::vector<unsigned char>& bytes() const noexcept { return bytes_; }
    /// Move the bytes out (the writer is left empty).
    [[nodiscard]] std::vector<unsigned char>&& take() noexcept { return std::move(bytes_); }

private:
    std::vector<unsigned char> bytes_;
};

/// Reads trivially copyable values from a byte span; every read past the end throws
/// grainlight::format_error (naming `context`), so parsers of hostile data never read out of bounds.
class ByteReader {
public:
    /// Reader over `size` bytes at `data` (not owned: the bytes must outlive the reader); `context`
    /// names the data in error messages.
    ByteReader(const unsigned char* data, std::size_t size, std::string context)
        : data_(data), size_(size), context_(std::move(context)) {}
    /// Reader over the bytes of `v` (not owned: `v` must outlive the reader and stay unchanged).
    explicit ByteReader(const std::vector<unsigned char>& v, std::string context = "payload")
        : ByteReader(v.data(), v.size(), std::move(context)) {}

    /// Read one value; format_error if fewer than sizeof(T) bytes remain.
    template <class T>
    [[nodiscard]] T get() {
        static_assert(std::is_trivially_copyable_v<T>);
        require(sizeof(T));
        T v;
        std::memcpy(&v, data_ + pos_, sizeof(T));
        pos_ += sizeof(T);
        return v;
    }
    /// Read `n` elements into `out` (resized). Checks n against the remaining bytes before allocating.
    template <class T>
    void get_array(std::vector<T>& out, std::uint64_t n) {
        static_assert(std::is_trivially_copyable_v<T>);
        if (n > remaining() / sizeof(T)) fail("array of " + std::to_string(n) + " elements exceeds the data");
        out.resize(static_cast<std::size_t>(n));
        if (n) std::memcpy(out.data(), data_ + pos_, static_cast<std::size_t>(n) * sizeof(T));
        pos_ += static_cast<std::size_t>(n) * sizeof(T);
    }
    /// Bytes not read yet.
    [[nodiscard]] std::size_t remaining() const noexcept { return size_ - pos_; }
    /// Bytes read so far.
    [[nodiscard]] std::size_t position() const noexcept { return pos_; }
    /// Throws unless every byte was consumed (trailing garbage means a layout mismatch).
    void expect_end() const {
        if (pos_ != size_) fail(std::to_string(size_ - pos_) + " unexpected trailing bytes");
    }
    /// Throw format_error "<context>: <what>".
    [[noreturn]] void fail(const std::string& what) const { raise_error<format_error>(context_ + ": " + what); }

private:
    void require(std::size_t n) const {
        if (n > size_ - pos_) fail("truncated (needed " + std::to_string(n) + " more bytes at offset " +
                                   std::to_string(pos_) + ")");
    }
    const unsigned char* data_;
    std::size_t size_;
    std::size_t pos_ = 0;
    std::string context_;
};

/// The decoded header of a container file.
struct ContainerHeader {
    std::uint32_t version = container_version;  ///< container layout version
    std::uint32_t kind = 0;                     ///< fourcc of the payload type
    std::uint32_t kind_version = 0;             ///< payload layout version
    std::uint64_t payload_size = 0;             ///< bytes after the header
    std::uint64_t payload_checksum = 0;         ///< fnv1a64 of the payload
};

namespace detail {
inline std::string kind_name(std::uint32_t k) {
    std::string s(4, '?');
    for (int i = 0; i < 4; ++i) {
        const char c = char((k >> (8 * i)) & 0xff);
        s[std::size_t(i)] = (c >= 32 && c < 127) ? c : '?';
    }
    return s;
}
inline std::array<unsigned char, container_header_size> encode_header(const ContainerHeader& h) {
    std::array<unsigned char, container_header_size> b{};
    std::memcpy(b.data(), container_magic.data(), 8);
    std::memcpy(b.data() + 8, &h.version, 4);
    std::memcpy(b.data() + 12, &h.kind, 4);
    std::memcpy(b.data() + 16, &h.kind_version, 4);
    const std::uint32_t reserved = 0;
    std::memcpy(b.data() + 20, &reserved, 4);
    std::memcpy(b.data() + 24, &h.payload_size, 8);
    std::memcpy(b.data() + 32, &h.payload_checksum, 8);
    const std::uint64_t hc = fnv1a64(b.data(), 40);
    std::memcpy(b.data() + 40, &hc, 8);
    return b;
}
/// A temporary file name next to `path`, unique per process and call.
inline std::filesystem::path temporary_path_for(const std::filesystem::path& path) {
    static std::atomic<std::uint64_t> counter{0};
    const auto ticks = static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
    const std::uint64_t tag = fnv1a64(&ticks, sizeof ticks, 0xcbf29ce484222325ull ^ counter.fetch_add(1));
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(tag));
    return std::filesystem::path(path.string() + ".tmp-" + hex);
}
}  // namespace detail

/// Write bytes to `path` atomically: write `path.tmp-XXXX`, flush, rename over `path`.
/// Throws grainlight::io_error (the temporary file is removed) if anything fails.
inline void write_file_atomic(const std::filesystem::path& path, const void* data, std::size_t size) {
    const auto tmp = detail::temporary_path_for(path);
    {
        std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
        if (!f) raise_error<io_error>("cannot open '" + tmp.string() + "' for writing");
        f.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
        f.flush();
        if (!f) {
            f.close();
            std::error_code ec;
            std::filesystem::remove(tmp, ec);
            raise_error<io_error>("write failed for '" + tmp.string() + "'");
        }
    }
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        std::error_code ec2;
        std::filesystem::remove(tmp, ec2);
        raise_error<io_error>("cannot rename '" + tmp.string() + "' to '" + path.string() + "': " + ec.message());
    }
}

/// Encode a complete container (header + payload) in memory.
[[nodiscard]] inline std::vector<unsigned char> encode_container(std::uint32_t kind, std::uint32_t kind_version,
                                                                 const std::vector<unsigned char>& payload) {
    ContainerHeader h;
    h.kind = kind;
    h.kind_version = kind_version;
    h.payload_size = payload.size();
    h.payload_checksum = fnv1a64(payload.data(), payload.size());
    const auto hb = detail::encode_header(h);
    std::vector<unsigned char> out(hb.begin(), hb.end());
    out.insert(out.end(), payload.begin(), payload.end());
    return out;
}

/// Write a container file atomically (see the format above). Throws grainlight::io_error.
inline void write_container_atomic(const std::filesystem::path& path, std::uint32_t kind, std::uint32_t kind_version,
                                   const std::vector<unsigned char>& payload) {
    const auto bytes = encode_container(kind, kind_version, payload);
    write_file_atomic(path, bytes.data(), bytes.size());
}

/// Validate an in-memory container (`context` names it in messages) and return its payload.
/// Throws grainlight::format_error on any mismatch (see the check order above).
[[nodiscard]] inline std::vector<unsigned char> decode_container(const unsigned char* data, std::size_t size,
                                                                 std::uint32_t expected_kind,
                                                                 std::uint32_t expected_kind_version,
                                                                 const std::string& context) {
    auto fail = [&](const std::string& what) -> void { raise_error<format_error>(context + ": " + what); };
    if (size < container_header_size)
        fail("truncated: " + std::to_string(size) + " bytes is shorter than the " +
             std::to_string(container_header_size) + "-byte header");
    if (std::memcmp(data, container_magic.data(), 8) != 0) fail("not a grainlight file (bad magic bytes)");
    std::uint64_t stored_hc = 0;
    std::memcpy(&stored_hc, data + 40, 8);
    if (fnv1a64(data, 40) != stored_hc) fail("corrupted header (header checksum mismatch)");
    ContainerHeader h;
    std::memcpy(&h.version, data + 8, 4);
    std::memcpy(&h.kind, data + 12, 4);
    std::memcpy(&h.kind_version, data + 16, 4);
    std::memcpy(&h.payload_size, data + 24, 8);
    std::memcpy(&h.payload_checksum, data + 32, 8);
    if (h.version != container_version)
        fail("unsupported container version " + std::to_string(h.version) + " (this build reads version " +
             std::to_string(container_version) + ")");
    if (h.kind != expected_kind)
        fail("holds '" + detail::kind_name(h.kind) + "' data, expected '" + detail::kind_name(expected_kind) + "'");
    if (h.kind_version != expected_kind_version)
        fail("unsupported '" + detail::kind_name(h.kind) + "' version " + std::to_string(h.kind_version) +
             " (this build reads version " + std::to_string(expected_kind_version) + ")");
    const std::uint64_t available = size - container_header_size;
    if (h.payload_size != available)
        fail(h.payload_size > available ? "truncated: header announces " + std::to_string(h.payload_size) +
                                              " payload bytes, file holds " + std::to_string(available)
                                        : "size mismatch: " + std::to_string(available - h.payload_size) +
                                              " unexpected trailing bytes");
    if (fnv1a64(data + container_header_size, available) != h.payload_checksum)
        fail("corrupted payload (checksum mismatch)");
    return std::vector<unsigned char>(data + container_header_size, data + size);
}

/// Read and validate a container file; returns its payload. Throws grainlight::io_error if the
/// file cannot be opened and grainlight::format_error if it is not a valid container of the
/// expected kind and version. Never allocates more than the file's actual size.
[[nodiscard]] inline std::vector<unsigned char> read_container(const std::filesystem::path& path,
                                                               std::uint32_t expected_kind,
                                                               std::uint32_t expected_kind_version) {
    std::ifstream f(path, std::ios::binary);
    if (!f) raise_error<io_error>("cannot open '" + path.string() + "' for reading");
    f.seekg(0, std::ios::end);
    const auto end = f.tellg();
    if (end < 0) raise_error<io_error>("cannot determine the size of '" + path.string() + "'");
    f.seekg(0, std::ios::beg);
    std::vector<unsigned char> bytes(static_cast<std::size_t>(end));
    if (!bytes.empty()) f.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!f) raise_error<io_error>("read failed for '" + path.string() + "'");
    return decode_container(bytes.data(), bytes.size(), expected_kind, expected_kind_version, "'" + path.string() + "'");
}

}  // namespace grainlight
