/* exr_read.cpp — sg_exr_read through OpenEXR's C++ library (Imf::InputFile,
 * which reads scanline and tiled parts alike and decodes DWAA/DWAB).
 *
 * Invariants:
 *  1. No exception crosses the extern "C" boundary: sg_exr_read's whole body
 *     runs inside one try whose handlers map Iex::ErrnoExc -> SG_ERR_IO,
 *     std::bad_alloc -> SG_ERR_NOMEM and every other exception ->
 *     SG_ERR_CORRUPT, always with the path and the library's message.
 *  2. The pixel array is owned by `img` until success hands it to *out; any
 *     failure (status or exception) frees it (image_guard).
 *  3. A file whose chunk table says pixels are missing (isComplete() false,
 *     e.g. a truncated file) is rejected before decoding: OpenEXR would
 *     otherwise fill the missing lines with the fill value or throw midway.
 *  4. Before any pixel is allocated or decoded, the data window is checked
 *     against the file size (smallest_file_bytes): a header claiming
 *     20000 x 10000 pixels in an 80 KB file took 10 s to fail in the
 *     decoder; now it fails at once, naming both figures.
 *  5. Before OpenEXR parses the header, every attribute's stated size is
 *     checked against the bytes the file has (header_sizes_fit): the
 *     library allocates and reads an attribute of the size it states, so a
 *     514-byte file whose "type" string claimed 1.9 GB took 11 s and 2 GB
 *     (found by the fuzzer).
 */
#include "io/exr_read.h"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <string>

#include <sys/stat.h>

#include <ImfChannelList.h>
#include <ImfCompression.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfRgbaFile.h>
#include <ImfTestFile.h>
#include <ImfArray.h>
#include <Iex.h>

extern "C" {
#include "core/alloc.h"
}

namespace {

/* Frees the image on every exit that did not hand it over (invariant 2). */
struct image_guard {
    sg_image img = {0, 0, nullptr, nullptr};
    ~image_guard() { sg_image_free(&img); }
};

const char *compression_name(Imf::Compression c)
{
    switch (c) {
    case Imf::NO_COMPRESSION: return "none";
    case Imf::RLE_COMPRESSION: return "rle";
    case Imf::ZIPS_COMPRESSION: return "zips";
    case Imf::ZIP_COMPRESSION: return "zip";
    case Imf::PIZ_COMPRESSION: return "piz";
    case Imf::PXR24_COMPRESSION: return "pxr24";
    case Imf::B44_COMPRESSION: return "b44";
    case Imf::B44A_COMPRESSION: return "b44a";
    case Imf::DWAA_COMPRESSION: return "dwaa";
    case Imf::DWAB_COMPRESSION: return "dwab";
    default: return "?";
    }
}

/* Luminance/chroma files: Imf::RgbaInputFile owns the chroma reconstruction
 * (filtering of the subsampled RY/BY and the file's chromaticities). */
void read_yc(const char *path, const Imath::Box2i &dw, sg_image *img)
{
    Imf::RgbaInputFile in(path);
    const int64_t w = img->width, h = img->height;
    Imf::Array2D<Imf::Rgba> px(h, w);
    /* The library indexes base[y * yStride + x * xStride] with (x, y) in the
     * data window; shift the base in integer arithmetic so no out-of-range
     * pointer is ever formed by us. */
    intptr_t base = reinterpret_cast<intptr_t>(&px[0][0]) -
                    (static_cast<intptr_t>(dw.min.x) + static_cast<intptr_t>(dw.min.y) * w) *
                        static_cast<intptr_t>(sizeof(Imf::Rgba));
    in.setFrameBuffer(reinterpret_cast<Imf::Rgba *>(base), 1, static_cast<size_t>(w));
    in.readPixels(dw.min.y, dw.max.y);
    for (int64_t y = 0; y < h; y++)
        for (int64_t x = 0; x < w; x++) {
            float *p = img->data + 3 * (y * w + x);
            p[0] = px[y][x].r;
            p[1] = px[y][x].g;
            p[2] = px[y][x].b;
        }
}

/* The fewest bytes a file of this header can have: per chunk its offset
 * table entry and chunk header, plus its pixels at the compression's
 * largest possible ratio: none 1, RLE 1/64 (2 bytes per run of up to
 * 128), zlib-based (ZIP, ZIPS, PXR24) and PIZ (Huffman with run codes,
 * below zlib's) 1/1032 (deflate's limit), B44/B44A 3/32 (a flat 4x4 half
 * block in 3 bytes), DWAA/DWAB 1/66048 (one DC value per 8x8 block through
 * zlib). Conservative: a real file is always at least this big. */
double smallest_file_bytes(const Imf::Header &hdr, int64_t w, int64_t h)
{
    double per_pixel = 0.0;
    for (Imf::ChannelList::ConstIterator it = hdr.channels().begin(); it != hdr.channels().end(); ++it) {
        const Imf::Channel &c = it.channel();
        double bytes = c.type == Imf::HALF ? 2.0 : 4.0;
        per_pixel += bytes / (double(c.xSampling > 0 ? c.xSampling : 1) * double(c.ySampling > 0 ? c.ySampling : 1));
    }
    double ratio = 1.0;
    int lines = 1; /* scanlines per chunk */
    switch (hdr.compression()) {
    case Imf::NO_COMPRESSION: ratio = 1.0; lines = 1; break;
    case Imf::RLE_COMPRESSION: ratio = 1.0 / 64.0; lines = 1; break;
    case Imf::ZIPS_COMPRESSION: ratio = 1.0 / 1032.0; lines = 1; break;
    case Imf::ZIP_COMPRESSION: ratio = 1.0 / 1032.0; lines = 16; break;
    case Imf::PIZ_COMPRESSION: ratio = 1.0 / 1032.0; lines = 32; break;
    case Imf::PXR24_COMPRESSION: ratio = 1.0 / 1032.0; lines = 16; break;
    case Imf::B44_COMPRESSION: case Imf::B44A_COMPRESSION: ratio = 3.0 / 32.0; lines = 32; break;
    case Imf::DWAA_COMPRESSION: ratio = 1.0 / 66048.0; lines = 32; break;
    case Imf::DWAB_COMPRESSION: ratio = 1.0 / 66048.0; lines = 256; break;
    default: ratio = 1.0 / 66048.0; lines = 256; break;
    }
    double chunks;
    if (hdr.hasTileDescription()) {
        const Imf::TileDescription &td = hdr.tileDescription();
        double tx = td.xSize > 0 ? td.xSize : 1, ty = td.ySize > 0 ? td.ySize : 1;
        chunks = std::ceil(double(w) / tx) * std::ceil(double(h) / ty); /* level 0 alone */
    } else {
        chunks = std::ceil(double(h) / lines);
    }
    /* 8: offset table entry; 8: chunk header (y or tile coordinates, size) */
    return chunks * 16.0 + double(w) * double(h) * per_pixel * ratio;
}

/* Invariant 5: walks the header(s) as the format lays them out — after the
 * 4-byte magic and 4-byte version, attributes of name\0 type\0 int32 size
 * and `size` bytes, a header ending at an empty name; a multi-part file has
 * several headers ending at an empty one — and checks that each value lies
 * inside the file. Returns SG_OK or SG_ERR_CORRUPT naming the attribute. */
sg_status header_sizes_fit(const char *path, sg_error *err)
{
    FILE *f = std::fopen(path, "rb");
    if (!f)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open: %s", path, std::strerror(errno));
    struct stat st;
    if (fstat(fileno(f), &st) != 0) {
        std::fclose(f);
        return sg_error_set(err, SG_ERR_IO, "%s: cannot stat: %s", path, std::strerror(errno));
    }
    const int64_t file_bytes = st.st_size;
    unsigned char version[8];
    sg_status status = SG_OK;
    if (std::fread(version, 1, 8, f) != 8) {
        status = sg_error_set(err, SG_ERR_CORRUPT, "%s: truncated in the version field", path);
    } else {
        const bool multipart = (version[5] & 0x10) != 0; /* flag bit 12 */
        int64_t at = 8;
        bool first_of_header = true;
        for (;;) {
            char name[256], type[256];
            int n = 0, c;
            while ((c = std::fgetc(f)) != EOF && c != 0 && n < 255)
                name[n++] = static_cast<char>(c);
            name[n] = 0;
            at += n + 1;
            if (c == EOF || c != 0) {
                status = sg_error_set(err, SG_ERR_CORRUPT, "%s: header truncated or an attribute name too long "
                                      "at byte %lld", path, static_cast<long long>(at));
                break;
            }
            if (n == 0) { /* end of a header; an empty header ends a multi-part list */
                if (!multipart || first_of_header)
                    break;
                first_of_header = true;
                continue;
            }
            first_of_header = false;
            int t = 0;
            while ((c = std::fgetc(f)) != EOF && c != 0 && t < 255)
                type[t++] = static_cast<char>(c);
            type[t] = 0;
            unsigned char sz[4];
            if (c != 0 || std::fread(sz, 1, 4, f) != 4) {
                status = sg_error_set(err, SG_ERR_CORRUPT, "%s: header truncated in attribute \"%s\"", path, name);
                break;
            }
            at += t + 1 + 4;
            const int64_t size = static_cast<int32_t>(static_cast<uint32_t>(sz[0]) | static_cast<uint32_t>(sz[1]) << 8 |
                                                      static_cast<uint32_t>(sz[2]) << 16 |
                                                      static_cast<uint32_t>(sz[3]) << 24);
            if (size < 0 || size > file_bytes - at) {
                status = sg_error_set(err, SG_ERR_CORRUPT,
                                      "%s: header attribute \"%s\" (%s) states %lld bytes; the file has %lld after it",
                                      path, name, type, static_cast<long long>(size),
                                      static_cast<long long>(file_bytes - at));
                break;
            }
            at += size;
            if (std::fseek(f, static_cast<long>(at), SEEK_SET) != 0) {
                status = sg_error_set(err, SG_ERR_IO, "%s: cannot seek: %s", path, std::strerror(errno));
                break;
            }
        }
    }
    std::fclose(f);
    return status;
}

/* Opens the file and checks what sg_exr_read and sg_exr_read_size share:
 * the file opens, it is a flat OpenEXR file, its data window is in range.
 * *in is created only when SG_OK is returned. */
sg_status open_exr(const char *path, std::unique_ptr<Imf::InputFile> *in, int64_t *w, int64_t *h,
                   sg_error *err)
{
    /* OpenEXR's own open failure reports errno only through an exception
     * whose text varies; an fopen first gives the plain OS reason. */
    FILE *probe = std::fopen(path, "rb");
    if (!probe)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open: %s", path, std::strerror(errno));
    std::fclose(probe);

    bool tiled = false, deep = false, multipart = false;
    if (!Imf::isOpenExrFile(path, tiled, deep, multipart))
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: not an OpenEXR file (bad magic or version)",
                            path);
    if (deep)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: deep OpenEXR files are not read", path);
    const sg_status sizes = header_sizes_fit(path, err);
    if (sizes != SG_OK)
        return sizes;

    std::unique_ptr<Imf::InputFile> file(new Imf::InputFile(path));
    const Imath::Box2i dw = file->header().dataWindow();
    *w = static_cast<int64_t>(dw.max.x) - dw.min.x + 1;
    *h = static_cast<int64_t>(dw.max.y) - dw.min.y + 1;
    if (*w <= 0 || *h <= 0 || *w > SG_IMAGE_MAX_DIM || *h > SG_IMAGE_MAX_DIM)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: data window %lldx%lld is out of range (1..%d)",
                            path, static_cast<long long>(*w), static_cast<long long>(*h),
                            SG_IMAGE_MAX_DIM);
    *in = std::move(file);
    return SG_OK;
}

sg_status read_exr(const char *path, sg_image *out, sg_exr_read_info *info, sg_error *err)
{
    std::unique_ptr<Imf::InputFile> file;
    int64_t w = 0, h = 0;
    const sg_status opened = open_exr(path, &file, &w, &h, err);
    if (opened != SG_OK)
        return opened;
    Imf::InputFile &in = *file;
    const Imf::Header &hdr = in.header();
    const Imath::Box2i dw = hdr.dataWindow();
    struct stat st;
    if (stat(path, &st) != 0)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot stat: %s", path, std::strerror(errno));
    const double need = smallest_file_bytes(hdr, w, h); /* invariant 4 */
    if (double(st.st_size) < need)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: data window %lldx%lld (%s compression) needs at least %.0f bytes; the file has %lld "
                            "(a bad header or a truncated file)",
                            path, static_cast<long long>(w), static_cast<long long>(h),
                            compression_name(hdr.compression()), std::ceil(need), static_cast<long long>(st.st_size));
    if (!in.isComplete()) /* invariant 3 */
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: truncated: pixel chunks are missing", path);

    const Imf::ChannelList &chl = hdr.channels();
    static const char *const rgb_names[3] = {"R", "G", "B"};
    const Imf::Channel *rgb[3];
    int n_rgb = 0;
    for (int c = 0; c < 3; c++) {
        rgb[c] = chl.findChannel(rgb_names[c]);
        if (rgb[c]) {
            n_rgb++;
            if (rgb[c]->xSampling != 1 || rgb[c]->ySampling != 1)
                return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: channel %s is subsampled (%dx%d)",
                                    path, rgb_names[c], rgb[c]->xSampling, rgb[c]->ySampling);
        }
    }
    const Imf::Channel *ych = chl.findChannel("Y");
    const bool chroma = chl.findChannel("RY") && chl.findChannel("BY");
    sg_exr_source source;
    if (n_rgb > 0)
        source = SG_EXR_SOURCE_RGB;
    else if (ych && chroma)
        source = SG_EXR_SOURCE_YC;
    else if (ych)
        source = SG_EXR_SOURCE_Y;
    else {
        std::string names;
        int listed = 0;
        for (Imf::ChannelList::ConstIterator it = chl.begin(); it != chl.end(); ++it, ++listed) {
            if (listed == 4) {
                names += ", ...";
                break;
            }
            names += std::string(listed ? ", " : "") + it.name();
        }
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: no R, G, B or Y channel (channels: %s)", path,
                            names.empty() ? "none" : names.c_str());
    }
    if (source == SG_EXR_SOURCE_Y && (ych->xSampling != 1 || ych->ySampling != 1))
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: channel Y is subsampled (%dx%d)", path,
                            ych->xSampling, ych->ySampling);

    image_guard g;
    if (sg_image_alloc(&g.img, static_cast<int>(w), static_cast<int>(h), nullptr) != SG_OK)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %lldx%lld pixels", path,
                            static_cast<long long>(w), static_cast<long long>(h));

    bool half = true;
    if (source == SG_EXR_SOURCE_YC) {
        read_yc(path, dw, &g.img);
        half = ych->type == Imf::HALF;
    } else {
        /* Every slice is FLOAT: the library converts half and uint. A slice
         * whose channel is absent is filled with 0 (the fill value). */
        const size_t xs = 3 * sizeof(float), ys = xs * static_cast<size_t>(w);
        Imf::FrameBuffer fb;
        if (source == SG_EXR_SOURCE_RGB) {
            for (int c = 0; c < 3; c++) {
                fb.insert(rgb_names[c], Imf::Slice::Make(Imf::FLOAT, g.img.data + c, dw, xs, ys));
                if (rgb[c] && rgb[c]->type != Imf::HALF)
                    half = false;
            }
        } else {
            fb.insert("Y", Imf::Slice::Make(Imf::FLOAT, g.img.data, dw, xs, ys));
            half = ych->type == Imf::HALF;
        }
        in.setFrameBuffer(fb);
        in.readPixels(dw.min.y, dw.max.y);
        if (source == SG_EXR_SOURCE_Y) {
            const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
            for (size_t i = 0; i < n; i++)
                g.img.data[3 * i + 1] = g.img.data[3 * i + 2] = g.img.data[3 * i];
        }
    }

    if (info) {
        info->tiled = hdr.hasTileDescription() ? 1 : 0;
        info->half = half ? 1 : 0;
        info->has_alpha = chl.findChannel("A") ? 1 : 0;
        info->source = source;
        std::snprintf(info->compression, sizeof info->compression, "%s",
                      compression_name(hdr.compression()));
    }
    *out = g.img; /* invariant 2: ownership moves to the caller */
    g.img = sg_image{0, 0, nullptr, nullptr};
    return SG_OK;
}

/* Runs body (which returns an sg_status) with every exception turned into
 * a status naming the path (invariant 1). */
template <class Body> sg_status guarded(const char *path, sg_error *err, Body body)
{
    try {
        return body();
    } catch (const Iex::ErrnoExc &e) {
        return sg_error_set(err, SG_ERR_IO, "%s: %s", path, e.what());
    } catch (const std::bad_alloc &) {
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory while decoding", path);
    } catch (const std::exception &e) {
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: %s", path, e.what());
    } catch (...) {
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: unknown error while decoding", path);
    }
}

} // namespace

extern "C" sg_status sg_exr_read_size(const char *path, int *width, int *height, sg_error *err)
{
    if (!width || !height)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_exr_read_size: width or height is NULL");
    if (!path || !path[0])
        return sg_error_set(err, SG_ERR_INVALID_ARG, "EXR path is empty");
    return guarded(path, err, [&]() {
        std::unique_ptr<Imf::InputFile> file;
        int64_t w = 0, h = 0;
        sg_status st = open_exr(path, &file, &w, &h, err);
        if (st == SG_OK) {
            *width = static_cast<int>(w);
            *height = static_cast<int>(h);
        }
        return st;
    });
}

extern "C" sg_status sg_exr_read(const char *path, sg_image *out, sg_exr_read_info *info, sg_error *err)
{
    if (!out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_exr_read: out is NULL");
    if (!path || !path[0])
        return sg_error_set(err, SG_ERR_INVALID_ARG, "EXR path is empty");
    return guarded(path, err, [&]() { return read_exr(path, out, info, err); });
}
