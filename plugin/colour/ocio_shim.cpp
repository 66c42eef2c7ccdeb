// OpenColorIO 2.1 behind the C interface of ocio_shim.h. Every entry point catches every
// exception and turns it into a result code and a message.
#include "ocio_shim.h"

#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>

#include <OpenColorIO/OpenColorIO.h>

#include "read_file.h"

namespace OCIO = OCIO_NAMESPACE;

namespace {

// Result codes of vbnl/result.h (the shim does not include C headers of the core).
enum {
    SHIM_OK = 0,
    SHIM_ERR_INVALID_ARGUMENT = 1,
    SHIM_ERR_OUT_OF_MEMORY = 2,
    SHIM_ERR_UNKNOWN_NAME = 4,
    SHIM_ERR_BACKEND = 6,
};

// OpenColorIO 2.1 has no built-in configs (ocio://default arrives in 2.2), so this one is
// embedded. The scene reference is linear Rec.709/sRGB primaries, D65 (what the renderer
// writes); the display reference is CIE XYZ D65. Only built-in transforms are used: linear
// Rec.709 -> XYZ goes through AP1 (inverse of AP1 -> linear Rec.709, then AP1 -> XYZ, both
// Bradford-adapted D60 <-> D65 so the adaptations cancel), and the ACES view goes on to AP0 and
// the ACES 1.0 SDR video output transform.
const char kBuiltinConfig[] = R"yaml(ocio_profile_version: 2.1
name: vbnl-builtin
description: vbnl embedded config built from OpenColorIO 2.1 built-in transforms
search_path: ""
strictparsing: true
luma: [0.2126, 0.7152, 0.0722]
roles:
  default: Linear Rec.709 (sRGB)
  scene_linear: Linear Rec.709 (sRGB)
  data: Raw
displays:
  sRGB:
    - !<View> {name: Standard, view_transform: Un-tone-mapped, display_colorspace: sRGB - Display}
    - !<View> {name: ACES 1.0 SDR-video, view_transform: ACES 1.0 - SDR Video, display_colorspace: sRGB - Display}
    - !<View> {name: Raw, colorspace: Raw}
active_displays: [sRGB]
active_views: [Standard, ACES 1.0 SDR-video, Raw]
default_view_transform: Un-tone-mapped
view_transforms:
  - !<ViewTransform>
    name: Un-tone-mapped
    from_scene_reference: !<GroupTransform>
      children:
        - !<BuiltinTransform> {style: UTILITY - ACES-AP1_to_LINEAR-REC709_BFD, direction: inverse}
        - !<BuiltinTransform> {style: UTILITY - ACES-AP1_to_CIE-XYZ-D65_BFD}
  - !<ViewTransform>
    name: ACES 1.0 - SDR Video
    from_scene_reference: !<GroupTransform>
      children:
        - !<BuiltinTransform> {style: UTILITY - ACES-AP1_to_LINEAR-REC709_BFD, direction: inverse}
        - !<BuiltinTransform> {style: UTILITY - ACES-AP1_to_CIE-XYZ-D65_BFD}
        - !<BuiltinTransform> {style: UTILITY - ACES-AP0_to_CIE-XYZ-D65_BFD, direction: inverse}
        - !<BuiltinTransform> {style: ACES-OUTPUT - ACES2065-1_to_CIE-XYZ-D65 - SDR-VIDEO_1.0}
display_colorspaces:
  - !<ColorSpace>
    name: sRGB - Display
    family: Display
    encoding: sdr-video
    from_display_reference: !<BuiltinTransform> {style: DISPLAY - CIE-XYZ-D65_to_sRGB}
colorspaces:
  - !<ColorSpace>
    name: Linear Rec.709 (sRGB)
    family: Scene-linear
    encoding: scene-linear
    isdata: false
  - !<ColorSpace>
    name: Raw
    family: Utility
    encoding: data
    isdata: true
)yaml";

int fail(char *msg, size_t n, int code, const char *fmt, ...)
{
    if (msg && n) {
        va_list ap;
        va_start(ap, fmt);
        std::vsnprintf(msg, n, fmt, ap);
        va_end(ap);
    }
    return code;
}

// Where the config comes from, for messages.
std::string config_label(const char *path)
{
    if (path)
        return std::string("OCIO config '") + path + "'";
    const char *env = std::getenv("OCIO");
    if (env && *env)
        return std::string("OCIO config '") + env + "' (from $OCIO)";
    return "the embedded OCIO config";
}

// A config file: read through read_file.h (a regular file; a FIFO is refused, not waited on), its
// folder the working folder its relative search paths start from, as CreateFromFile makes it.
OCIO::ConstConfigRcPtr load_config_file(const char *path)
{
    const char *why = nullptr;
    FILE *f = vbi_read_fopen(path, nullptr, &why);
    if (!f)
        throw OCIO::Exception(why);
    std::string text;
    char buf[65536];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0)
        text.append(buf, n);
    const bool failed = std::ferror(f) != 0;
    std::fclose(f);
    if (failed)
        throw OCIO::Exception("read error");
    std::istringstream in(text);
    OCIO::ConfigRcPtr cfg = OCIO::Config::CreateFromStream(in)->createEditableCopy();
    const char *slash = std::strrchr(path, '/');
    cfg->setWorkingDir(slash ? std::string(path, slash == path ? 1 : (size_t)(slash - path)).c_str() : ".");
    return cfg;
}

OCIO::ConstConfigRcPtr load_config(const char *path)
{
    if (path)
        return load_config_file(path);
    const char *env = std::getenv("OCIO");
    if (env && *env)
        return load_config_file(env);
    std::istringstream in(kBuiltinConfig);
    return OCIO::Config::CreateFromStream(in);
}

std::string describe(const OCIO::ConstConfigRcPtr &cfg)
{
    std::string out;
    for (int d = 0; d < cfg->getNumDisplays(); ++d) {
        const char *disp = cfg->getDisplay(d);
        out += (d ? "; " : "") + std::string("display '") + disp + "' with views ";
        for (int v = 0; v < cfg->getNumViews(disp); ++v)
            out += (v ? ", '" : "'") + std::string(cfg->getView(disp, v)) + "'";
    }
    return out;
}

} // namespace

extern "C" const char *vbi_ocio_builtin_config(void)
{
    return kBuiltinConfig;
}

extern "C" int vbi_ocio_describe(const char *config_path, char *buf, size_t buf_size, char *msg,
                                  size_t msg_size)
{
    try {
        OCIO::ConstConfigRcPtr cfg = load_config(config_path);
        std::snprintf(buf, buf_size, "%s", describe(cfg).c_str());
        return SHIM_OK;
    } catch (const std::exception &e) {
        return fail(msg, msg_size, SHIM_ERR_BACKEND, "%s: %s", config_label(config_path).c_str(), e.what());
    } catch (...) {
        return fail(msg, msg_size, SHIM_ERR_BACKEND, "%s: unknown error", config_label(config_path).c_str());
    }
}

extern "C" int vbi_ocio_apply(const char *config_path, const char *display, const char *view, float *pixels,
                               uint32_t width, uint32_t height, uint32_t channels, char *msg, size_t msg_size)
{
    if (!pixels || (channels != 3 && channels != 4) || width == 0 || height == 0)
        return fail(msg, msg_size, SHIM_ERR_INVALID_ARGUMENT, "colour view: bad image (%ux%u, %u channels)",
                    width, height, channels);
    std::string label = config_label(config_path);
    try {
        OCIO::ConstConfigRcPtr cfg = load_config(config_path);
        cfg->validate();
        const char *disp = display ? display : cfg->getDefaultDisplay();
        bool disp_ok = false;
        for (int d = 0; d < cfg->getNumDisplays(); ++d)
            disp_ok = disp_ok || std::strcmp(cfg->getDisplay(d), disp) == 0;
        if (!disp_ok)
            return fail(msg, msg_size, SHIM_ERR_UNKNOWN_NAME, "unknown display '%s' in %s; available: %s", disp,
                        label.c_str(), describe(cfg).c_str());
        const char *v = view ? view : cfg->getDefaultView(disp);
        bool view_ok = false;
        for (int i = 0; i < cfg->getNumViews(disp); ++i)
            view_ok = view_ok || std::strcmp(cfg->getView(disp, i), v) == 0;
        if (!view_ok)
            return fail(msg, msg_size, SHIM_ERR_UNKNOWN_NAME, "unknown view '%s' of display '%s' in %s; available: %s",
                        v, disp, label.c_str(), describe(cfg).c_str());
        OCIO::DisplayViewTransformRcPtr t = OCIO::DisplayViewTransform::Create();
        t->setSrc(OCIO::ROLE_SCENE_LINEAR);
        t->setDisplay(disp);
        t->setView(v);
        OCIO::ConstCPUProcessorRcPtr cpu = cfg->getProcessor(t)->getDefaultCPUProcessor();
        OCIO::PackedImageDesc img(pixels, width, height, channels);
        cpu->apply(img);
        return SHIM_OK;
    } catch (const std::bad_alloc &) {
        return fail(msg, msg_size, SHIM_ERR_OUT_OF_MEMORY, "colour view: out of memory");
    } catch (const std::exception &e) {
        return fail(msg, msg_size, SHIM_ERR_BACKEND, "%s: %s", label.c_str(), e.what());
    } catch (...) {
        return fail(msg, msg_size, SHIM_ERR_BACKEND, "%s: unknown error", label.c_str());
    }
}
