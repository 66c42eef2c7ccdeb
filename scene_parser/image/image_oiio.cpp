// Image files other than PNG through OpenImageIO: a module of its own (vbnl_image_oiio.so),
// loaded by image_read.c the first time a scene names such a file, so that OpenImageIO and the
// libraries it needs are not loaded by every run. Its one entry point (pov_image.h's reader
// contract) catches every exception and turns it into a result and a sentence.
#include "pov_image.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

namespace {

void say(char *why, size_t n, const std::string &s)
{
    if (why && n)
        std::snprintf(why, n, "%s", s.c_str());
}

// How the stored values relate to light: OpenImageIO names it in oiio:ColorSpace; float formats
// are linear, integer formats without a name are sRGB (POV-Ray 3.7's default file gamma). Also
// their depth (out->bits: 0 for float formats).
void encoding_of(const OIIO::ImageSpec &spec, pov_image_data *out)
{
    std::string cs = spec.get_string_attribute("oiio:ColorSpace");
    float gamma = spec.get_float_attribute("oiio:Gamma", 0.0f);
    const bool is_float = spec.format.is_floating_point();
    out->bits = is_float ? 0u : (uint32_t)(spec.format.size() * 8);
    out->gamma = 0.0;
    if (cs == "Linear" || cs == "linear" || cs == "scene_linear" || (cs.empty() && is_float)) {
        out->encoding = POV_IMAGE_LINEAR;
    } else if (cs.rfind("GammaCorrected", 0) == 0 || cs.rfind("Gamma", 0) == 0) {
        double g = gamma > 0.0f ? gamma : std::atof(cs.c_str() + (cs[5] == 'C' ? 14 : 5));
        if (g > 0.0) {
            out->encoding = POV_IMAGE_GAMMA;
            out->gamma = g;
        } else {
            out->encoding = POV_IMAGE_SRGB;
        }
    } else {
        out->encoding = POV_IMAGE_SRGB;
    }
}

} // namespace

// The image in `file` (opened by the caller, who keeps it: image_read.c opens only regular files),
// `path` its name: OpenImageIO picks the format by the name's extension, then by the contents.
extern "C" __attribute__((visibility("default"))) int vbnl_oiio_image_read_stream(const char *path, FILE *file,
                                                                                  pov_image_data *out, char *why,
                                                                                  size_t why_size)
{
    std::memset(out, 0, sizeof(*out));
    try {
        OIIO::Filesystem::IOFile proxy(file, OIIO::Filesystem::IOProxy::Read);
        auto in = OIIO::ImageInput::open(path, nullptr, &proxy);
        if (!in) {
            std::string e = OIIO::geterror();
            say(why, why_size, e.empty() ? "not an image OpenImageIO reads" : e);
            return -1;
        }
        const OIIO::ImageSpec &spec = in->spec();
        if (spec.width <= 0 || spec.height <= 0 || spec.width > 65536 || spec.height > 65536 || spec.nchannels < 1) {
            say(why, why_size, "the image is empty or larger than 65536 on a side");
            return -1;
        }
        const int nc = spec.nchannels;
        const size_t texels = (size_t)spec.width * (size_t)spec.height;
        if (texels * (size_t)nc > ((size_t)1 << 28)) {
            say(why, why_size, "the image has more than 2^28 values");
            return -1;
        }
        std::vector<float> all(texels * (size_t)nc);
        if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, all.data())) {
            say(why, why_size, in->geterror());
            return -1;
        }
        // grey, grey + alpha, RGB or RGBA: the first channels; alpha where OpenImageIO finds one
        int keep = nc >= 4 ? 4 : nc;
        if (nc > 4 || (nc >= 3 && spec.alpha_channel >= 0 && spec.alpha_channel != 3))
            keep = spec.alpha_channel == 3 ? 4 : 3;
        if (nc == 2 && spec.alpha_channel != 1)
            keep = 1;
        float *t = static_cast<float *>(std::malloc(texels * (size_t)keep * sizeof(float)));
        if (!t) {
            say(why, why_size, "out of memory");
            return -1;
        }
        for (size_t i = 0; i < texels; ++i)
            for (int k = 0; k < keep; ++k)
                t[i * keep + k] = all[i * nc + k];
        out->width = (uint32_t)spec.width;
        out->height = (uint32_t)spec.height;
        out->channels = (uint32_t)keep;
        out->texels = t;
        out->indices = nullptr;
        encoding_of(spec, out);
        in->close();
        return 0;
    } catch (const std::exception &e) {
        say(why, why_size, e.what());
    } catch (...) {
        say(why, why_size, "OpenImageIO failed");
    }
    std::free(out->texels);
    out->texels = nullptr;
    return -1;
}
