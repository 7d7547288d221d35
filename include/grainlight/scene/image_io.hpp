/// @file grainlight/scene/image_io.hpp
/// Image files: OpenEXR float RGB output and input (OpenEXR 3.1, `FrameBuffer` + `OutputFile`,
/// 32-bit float channels R, G, B; `RgbaOutputFile` would store half floats) and an 8-bit sRGB
/// PNG preview (libpng). This is the only grainlight header that includes OpenEXR or libpng.
///
/// Writers write `<path>.tmp` and rename it over `path`, so a crash never leaves a half-written
/// image. Readers throw grainlight::io_error when the file cannot be opened and
/// grainlight::format_error when it is not a valid (or is a truncated) EXR file; they never crash
/// on hostile input.
#pragma once

#include <png.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfTestFile.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/serialization.hpp"
#include "grainlight/scene/film.hpp"

namespace grainlight {

namespace detail {

/// Rename `tmp` over `path`; on failure remove `tmp` and throw io_error.
inline void commit_temp_file(const std::filesystem::path& tmp, const std::filesystem::path& path,
                             const char* where) {
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        std::filesystem::remove(tmp, ec);
        throw io_error(std::string(where) + ": cannot rename '" + tmp.string() + "' to '" + path.string() + "'");
    }
}

/// A temporary name next to `path`, unique per process and call (the same scheme as the
/// container writer), so two writers of one target never share a temporary file.
inline std::filesystem::path temp_path_for(const std::filesystem::path& path) { return temporary_path_for(path); }

/// Linear -> sRGB transfer function (IEC 61966-2-1), input clamped to [0, 1].
[[nodiscard]] inline double srgb_encode(double v) noexcept {
    v = std::clamp(v, 0.0, 1.0);
    return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

/// libpng's error callback: longjmp back into write_png_rows (no C++ objects live across it).
inline void png_error_longjmp(png_structp png, png_const_charp) { png_longjmp(png, 1); }
inline void png_warning_ignore(png_structp, png_const_charp) {}

/// Write 8-bit RGB rows with libpng into an open FILE*. Returns false on a libpng error. Only
/// plain pointers live across setjmp here.
inline bool write_png_rows(std::FILE* fp, int width, int height, const unsigned char* data) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, png_error_longjmp, png_warning_ignore);
    if (!png) return false;
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, nullptr);
        return false;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return false;
    }
    png_init_io(png, fp);
    png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    for (int y = 0; y < height; ++y)
        png_write_row(png, const_cast<png_bytep>(data + std::size_t(y) * std::size_t(width) * 3));
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    return true;
}

}  // namespace detail

/// Write `img` as an OpenEXR file with 32-bit float channels R, G, B (ZIP compression).
/// Atomic (temporary file + rename). Throws invalid_argument for an empty or inconsistent image
/// and io_error when the file cannot be written.
inline void write_exr(const std::filesystem::path& path, const Image& img) {
    check_argument(img.width >= 1 && img.height >= 1, "write_exr", "image size", img.width * img.height, ">= 1 pixel");
    check_argument(img.rgb.size() == std::size_t(3) * std::size_t(img.width) * std::size_t(img.height), "write_exr",
                   "image.rgb.size()", img.rgb.size(), "3 * width * height");
    const auto tmp = detail::temp_path_for(path);
    try {
        Imf::Header header(img.width, img.height);
        header.compression() = Imf::ZIP_COMPRESSION;
        for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
        Imf::OutputFile file(tmp.string().c_str(), header);
        Imf::FrameBuffer fb;
        char* base = reinterpret_cast<char*>(const_cast<float*>(img.rgb.data()));
        const std::size_t xs = 3 * sizeof(float), ys = xs * std::size_t(img.width);
        fb.insert("R", Imf::Slice(Imf::FLOAT, base + 0 * sizeof(float), xs, ys));
        fb.insert("G", Imf::Slice(Imf::FLOAT, base + 1 * sizeof(float), xs, ys));
        fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
        file.setFrameBuffer(fb);
        file.writePixels(img.height);
    } catch (const std::exception& e) {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
        throw io_error("write_exr: cannot write '" + path.string() + "': " + e.what());
    }
    detail::commit_temp_file(tmp, path, "write_exr");
}

/// Read an OpenEXR file into a float RGB image. Channels R, G, B are read (a luminance-only file
/// with channel Y is replicated to grey; missing colour channels read as 0). Throws io_error if
/// `path` cannot be opened and format_error if it is not a readable EXR file (wrong magic,
/// truncated, corrupt, absurd size, none of R/G/B/Y).
[[nodiscard]] inline Image read_exr(const std::filesystem::path& path) {
    {
        std::ifstream probe(path, std::ios::binary);
        if (!probe) throw io_error("read_exr: cannot open '" + path.string() + "' (path)");
    }
    try {
        if (!Imf::isOpenExrFile(path.string().c_str()))
            throw format_error("read_exr: '" + path.string() + "' is not an OpenEXR file");
        Imf::InputFile file(path.string().c_str());
        const Imath::Box2i dw = file.header().dataWindow();
        const long long w = (long long)dw.max.x - dw.min.x + 1, h = (long long)dw.max.y - dw.min.y + 1;
        if (w < 1 || h < 1 || w > 32768 || h > 32768)
            throw format_error("read_exr: '" + path.string() + "' has an invalid data window");
        const Imf::ChannelList& ch = file.header().channels();
        const bool has_rgb = ch.findChannel("R") || ch.findChannel("G") || ch.findChannel("B");
        const bool has_y = ch.findChannel("Y") != nullptr;
        if (!has_rgb && !has_y)
            throw format_error("read_exr: '" + path.string() + "' has none of the channels R, G, B, Y");
        Image img{int(w), int(h)};
        const std::size_t xs = 3 * sizeof(float), ys = xs * std::size_t(w);
        // Slice base so that pixel (dw.min.x, dw.min.y) maps to rgb[0].
        char* base = reinterpret_cast<char*>(img.rgb.data()) - std::ptrdiff_t(dw.min.x) * std::ptrdiff_t(xs) -
                     std::ptrdiff_t(dw.min.y) * std::ptrdiff_t(ys);
        Imf::FrameBuffer fb;
        if (has_rgb) {
            fb.insert("R", Imf::Slice(Imf::FLOAT, base + 0 * sizeof(float), xs, ys, 1, 1, 0.0));
            fb.insert("G", Imf::Slice(Imf::FLOAT, base + 1 * sizeof(float), xs, ys, 1, 1, 0.0));
            fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys, 1, 1, 0.0));
        } else {
            fb.insert("Y", Imf::Slice(Imf::FLOAT, base, xs, ys, 1, 1, 0.0));
        }
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        if (!has_rgb)
            for (std::size_t i = 0; i < img.rgb.size(); i += 3) img.rgb[i + 1] = img.rgb[i + 2] = img.rgb[i];
        return img;
    } catch (const format_error&) {
        throw;
    } catch (const std::exception& e) {
        throw format_error("read_exr: '" + path.string() + "' is corrupt or truncated: " + e.what());
    }
}

/// Options of the PNG preview: pixel value v maps to srgb(clamp(v * 2^exposure, 0, 1)).
struct PngOptions {
    double exposure = 0.0;  ///< stops (EV): scale 2^exposure before the clamp
};

/// Write an 8-bit sRGB PNG preview of a linear image (exposure, clamp, sRGB transfer curve).
/// Non-finite values are written as 0. Atomic (temporary file + rename); io_error on failure.
inline void write_png(const std::filesystem::path& path, const Image& img, PngOptions opt = {}) {
    check_argument(img.width >= 1 && img.height >= 1, "write_png", "image size", img.width * img.height, ">= 1 pixel");
    check_argument(img.rgb.size() == std::size_t(3) * std::size_t(img.width) * std::size_t(img.height), "write_png",
                   "image.rgb.size()", img.rgb.size(), "3 * width * height");
    check_finite("write_png", "exposure", opt.exposure);
    const double scale = std::exp2(opt.exposure);
    std::vector<unsigned char> bytes(img.rgb.size());
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        const double v = double(img.rgb[i]);
        const double e = std::isfinite(v) ? detail::srgb_encode(v * scale) : 0.0;
        bytes[i] = static_cast<unsigned char>(std::lround(e * 255.0));
    }
    const auto tmp = detail::temp_path_for(path);
    std::FILE* fp = std::fopen(tmp.string().c_str(), "wb");
    if (!fp) throw io_error("write_png: cannot open '" + tmp.string() + "' for writing (path)");
    const bool ok = detail::write_png_rows(fp, img.width, img.height, bytes.data());
    const bool closed = std::fclose(fp) == 0;
    if (!ok || !closed) {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
        throw io_error("write_png: writing '" + path.string() + "' failed");
    }
    detail::commit_temp_file(tmp, path, "write_png");
}

}  // namespace grainlight
