/* OpenEXR writer and reader on the OpenEXR 3.1 C core API. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <openexr.h>

#include "atomic_file.h"
#include "image_io.h"
#include "read_file.h"

#define VBI_EXR_MAX_CHANNELS_PER_LAYER 64u
#define VBI_EXR_MAX_NAME 255u

/* ---------------------------------------------------------------------------------------------- */
/* Half precision (IEEE 754 binary16), done here so the library's conversion paths are not used.   */

static uint16_t vbi_float_to_half(float f)
{
    uint32_t x;
    memcpy(&x, &f, 4);
    uint16_t sign = (uint16_t)((x >> 16) & 0x8000u);
    uint32_t ax = x & 0x7fffffffu;
    if (ax >= 0x7f800000u) /* inf or NaN; keep NaN quiet and non-zero */
        return (uint16_t)(sign | 0x7c00u | (ax > 0x7f800000u ? 0x200u | ((ax >> 13) & 0x3ffu) : 0));
    if (ax >= 0x477ff000u) /* rounds to >= 65520: overflow */
        return (uint16_t)(sign | 0x7c00u);
    if (ax < 0x38800000u) { /* below the smallest normal half: denormal or zero */
        if (ax < 0x33000000u) /* < 2^-25 rounds to zero */
            return sign;
        uint32_t e = ax >> 23;
        uint32_t m = (ax & 0x7fffffu) | 0x800000u;
        uint32_t shift = 126u - e; /* 14..24 */
        uint32_t h = m >> shift;
        uint32_t rem = m & ((1u << shift) - 1u), half = 1u << (shift - 1u);
        if (rem > half || (rem == half && (h & 1u)))
            h++;
        return (uint16_t)(sign | h);
    }
    /* normal: rebias exponent, round mantissa to nearest even (a carry into the exponent is right) */
    uint32_t h = ((ax - 0x38000000u) >> 13);
    uint32_t rem = ax & 0x1fffu;
    if (rem > 0x1000u || (rem == 0x1000u && (h & 1u)))
        h++;
    return (uint16_t)(sign | h);
}

static float vbi_half_to_float(uint16_t h)
{
    uint32_t sign = (uint32_t)(h & 0x8000u) << 16;
    uint32_t e = (h >> 10) & 0x1fu, m = h & 0x3ffu, x;
    if (e == 0) {
        if (m == 0) {
            x = sign;
        } else { /* denormal: normalise */
            e = 113;
            while (!(m & 0x400u)) {
                m <<= 1;
                e--;
            }
            x = sign | (e << 23) | ((m & 0x3ffu) << 13);
        }
    } else if (e == 31) {
        x = sign | 0x7f800000u | (m << 13);
    } else {
        x = sign | ((e + 112u) << 23) | (m << 13);
    }
    float f;
    memcpy(&f, &x, 4);
    return f;
}

/* ---------------------------------------------------------------------------------------------- */
/* Per-call state: our write callback gets it as user_data, the error callback as below.          */

typedef struct vbi_exr_io {
    int fd;
    int64_t size; /* reading: the file's size */
    int write_errno;
    int read_errno; /* reading: errno of a failed read (not a file that ends early, which is damage) */
    exr_result_t code; /* first error the library reported */
    char msg[512];
} vbi_exr_io;

/* The error callback cannot use exr_get_user_data: in write mode OpenEXR 3.1 calls the callback
 * with the context's non-recursive mutex held and exr_get_user_data takes it again (deadlock). So
 * the per-call record is reached through a thread-local pointer that only lives for one call. */
static _Thread_local vbi_exr_io *vbi_exr_current_io;

static void vbi_exr_on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    vbi_exr_io *io = vbi_exr_current_io;
    if (io && io->code == EXR_ERR_SUCCESS) {
        io->code = code;
        snprintf(io->msg, sizeof io->msg, "%s", msg ? msg : "");
    }
}

static int64_t vbi_exr_pwrite(exr_const_context_t ctxt, void *userdata, const void *buffer,
                               uint64_t sz, uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    vbi_exr_io *io = userdata;
    const char *p = buffer;
    uint64_t done = 0;
    while (done < sz) {
        ssize_t n = pwrite(io->fd, p + done, (size_t)(sz - done), (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            io->write_errno = n < 0 ? errno : EIO;
            if (error_cb)
                error_cb(ctxt, EXR_ERR_WRITE_IO, "%s", strerror(io->write_errno));
            return -1;
        }
        done += (uint64_t)n;
    }
    return (int64_t)done;
}

/* Reading through our descriptor (read_file.h: a regular file, opened without waiting on a FIFO). */
static int64_t vbi_exr_pread(exr_const_context_t ctxt, void *userdata, void *buffer, uint64_t sz,
                              uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    vbi_exr_io *io = userdata;
    char *p = buffer;
    uint64_t done = 0;
    while (done < sz) {
        ssize_t n = pread(io->fd, p + done, (size_t)(sz - done), (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0) {
            io->read_errno = errno;
            if (error_cb)
                error_cb(ctxt, EXR_ERR_READ_IO, "%s", strerror(errno));
            return -1;
        }
        if (n == 0)
            break; /* the end of the file: a short read, which the library reports */
        done += (uint64_t)n;
    }
    return (int64_t)done;
}

static int64_t vbi_exr_size(exr_const_context_t ctxt, void *userdata)
{
    (void)ctxt;
    return ((const vbi_exr_io *)userdata)->size;
}

/* Library failure -> vbnl error, preferring the specific message the callback captured. */
static vbnl_result vbi_exr_fail(vbnl_error *err, const vbi_exr_io *io, exr_result_t rv,
                                 vbnl_result code, const char *verb, const char *path)
{
    if (io->write_errno)
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot %s '%s': %s", verb, path,
                              strerror(io->write_errno));
    const char *detail = io->msg[0] ? io->msg : exr_get_default_error_message(rv);
    return vbnl_error_set(err, code, "cannot %s '%s': %s (%s)", verb, path, detail,
                          exr_get_error_code_as_string(rv));
}

/* ---------------------------------------------------------------------------------------------- */
/* Writing                                                                                        */

typedef struct vbi_exr_out_channel {
    char name[VBI_EXR_MAX_NAME + 1];
    uint32_t layer, component;
} vbi_exr_out_channel;

static const char *const vbi_default_names[5][4] = {
    {NULL}, {"Y"}, {NULL}, {"R", "G", "B"}, {"R", "G", "B", "A"},
};

static const char *vbi_layer_channel_name(const vbi_image_layer *l, uint32_t c)
{
    if (l->channel_names)
        return l->channel_names[c];
    return l->channels <= 4 ? vbi_default_names[l->channels][c] : NULL;
}

static int vbi_is_reserved_attr(const char *name)
{
    static const char *const reserved[] = {
        "channels", "compression", "dataWindow", "displayWindow", "lineOrder",
        "pixelAspectRatio", "screenWindowCenter", "screenWindowWidth", "chromaticities",
        "tiles", "type", "name", "version", "chunkCount",
    };
    for (size_t i = 0; i < sizeof reserved / sizeof reserved[0]; i++)
        if (strcmp(name, reserved[i]) == 0)
            return 1;
    return 0;
}

static vbnl_result vbi_exr_check_write_args(const char *path, uint32_t width, uint32_t height,
                                             const vbi_image_layer *layers, uint32_t layer_count,
                                             const vbi_image_attr *attrs, uint32_t attr_count,
                                             vbnl_error *err)
{
    const char *p = path ? path : "(null)";
    if (!path || !path[0])
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "cannot write EXR: no path given");
    if (width == 0 || height == 0 || width > INT32_MAX || height > INT32_MAX)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "cannot write '%s': invalid image size %ux%u", p, width, height);
    if (!layers || layer_count == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "cannot write '%s': no layers", p);
    if (attr_count > 0 && !attrs)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "cannot write '%s': attrs is NULL but attr_count is %u", p,
                              attr_count);
    for (uint32_t i = 0; i < layer_count; i++) {
        const vbi_image_layer *l = &layers[i];
        if (!l->name || !l->data)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "cannot write '%s': layer %u has a NULL name or data", p, i);
        if (l->channels == 0 || l->channels > VBI_EXR_MAX_CHANNELS_PER_LAYER)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "cannot write '%s': layer '%s' has %u channels", p, l->name,
                                  l->channels);
        for (uint32_t c = 0; c < l->channels; c++) {
            const char *cn = vbi_layer_channel_name(l, c);
            if (!cn || !cn[0])
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "cannot write '%s': layer '%s' channel %u has no name", p,
                                      l->name, c);
        }
    }
    for (uint32_t i = 0; i < attr_count; i++) {
        const vbi_image_attr *a = &attrs[i];
        if (!a->name || !a->name[0] || strlen(a->name) > VBI_EXR_MAX_NAME)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "cannot write '%s': attribute %u has no or too long a name", p, i);
        if (vbi_is_reserved_attr(a->name))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "cannot write '%s': attribute name '%s' is reserved", p, a->name);
        if ((unsigned)a->type > VBI_IMAGE_ATTR_DOUBLE ||
            (a->type == VBI_IMAGE_ATTR_STRING && !a->value.s))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "cannot write '%s': attribute '%s' has a bad type or value", p,
                                  a->name);
        for (uint32_t j = 0; j < i; j++)
            if (strcmp(attrs[j].name, a->name) == 0)
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "cannot write '%s': attribute '%s' given twice", p, a->name);
    }
    return VBNL_OK;
}

/* Flattens the layers into full channel names; checks length and uniqueness. */
static vbnl_result vbi_exr_plan_channels(const char *path, const vbi_image_layer *layers,
                                          uint32_t layer_count, vbi_exr_out_channel **out,
                                          uint32_t *out_count, int *long_names, vbnl_error *err)
{
    uint32_t n = 0;
    for (uint32_t i = 0; i < layer_count; i++)
        n += layers[i].channels;
    vbi_exr_out_channel *ch = calloc(n, sizeof *ch);
    if (!ch)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot write '%s': out of memory",
                              path);
    uint32_t k = 0;
    *long_names = 0;
    for (uint32_t i = 0; i < layer_count; i++) {
        for (uint32_t c = 0; c < layers[i].channels; c++, k++) {
            const char *cn = vbi_layer_channel_name(&layers[i], c);
            int len = layers[i].name[0]
                          ? snprintf(ch[k].name, sizeof ch[k].name, "%s.%s", layers[i].name, cn)
                          : snprintf(ch[k].name, sizeof ch[k].name, "%s", cn);
            if (len < 0 || (size_t)len > VBI_EXR_MAX_NAME) {
                free(ch);
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "cannot write '%s': channel name '%s.%s' is longer than %u "
                                      "bytes", path, layers[i].name, cn, VBI_EXR_MAX_NAME);
            }
            if (len > 31) /* the EXR limit unless the "long names" flag is set */
                *long_names = 1;
            ch[k].layer = i;
            ch[k].component = c;
            for (uint32_t j = 0; j < k; j++) {
                if (strcmp(ch[j].name, ch[k].name) == 0) {
                    vbnl_result r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                                   "cannot write '%s': channel '%s' given twice",
                                                   path, ch[k].name);
                    free(ch);
                    return r;
                }
            }
        }
    }
    *out = ch;
    *out_count = n;
    return VBNL_OK;
}

/* Writes every scanline chunk. `src[k]` is the base of output channel k's layer (float or half). */
static exr_result_t vbi_exr_write_chunks(exr_context_t ctxt, uint32_t width, int32_t y0, uint32_t height,
                                          const vbi_exr_out_channel *ch, uint32_t n,
                                          const vbi_image_layer *layers,
                                          const uint8_t *const *layer_base, int half_float)
{
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int32_t lines = 1;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctxt, 0, &lines);
    const int32_t elem = half_float ? 2 : 4;
    int initialised = 0;
    /* y counts rows of the data window; chunks start at its first row, `lines` apart */
    for (int32_t y = 0; rv == EXR_ERR_SUCCESS && y < (int32_t)height; y += lines) {
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(ctxt, 0, y0 + y, &cinfo);
        if (rv != EXR_ERR_SUCCESS)
            break;
        rv = initialised ? exr_encoding_update(ctxt, 0, &cinfo, &enc)
                         : exr_encoding_initialize(ctxt, 0, &cinfo, &enc);
        if (rv != EXR_ERR_SUCCESS)
            break;
        initialised = 1;
        /* The pipeline's channels are in file order (sorted by name): match ours by name. */
        for (int16_t c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ec = &enc.channels[c];
            const vbi_exr_out_channel *oc = NULL;
            for (uint32_t k = 0; k < n && !oc; k++)
                if (strcmp(ch[k].name, ec->channel_name) == 0)
                    oc = &ch[k];
            if (!oc) {
                rv = EXR_ERR_INVALID_ARGUMENT;
                break;
            }
            const vbi_image_layer *l = &layers[oc->layer];
            size_t row = (size_t)width * l->channels * (size_t)elem;
            ec->user_bytes_per_element = (int16_t)elem;
            ec->user_data_type = (uint16_t)(half_float ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT);
            ec->user_pixel_stride = (int32_t)(l->channels * (uint32_t)elem);
            ec->user_line_stride = (int32_t)row;
            ec->encode_from_ptr = layer_base[oc->layer] + (size_t)y * row +
                                  (size_t)oc->component * (size_t)elem;
        }
        if (rv != EXR_ERR_SUCCESS)
            break;
        rv = exr_encoding_choose_default_routines(ctxt, 0, &enc);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(ctxt, 0, &enc);
    }
    if (initialised)
        exr_encoding_destroy(ctxt, &enc);
    return rv;
}

static exr_result_t vbi_exr_set_attr(exr_context_t ctxt, const vbi_image_attr *a)
{
    switch (a->type) {
    case VBI_IMAGE_ATTR_STRING: return exr_attr_set_string(ctxt, 0, a->name, a->value.s);
    case VBI_IMAGE_ATTR_INT: return exr_attr_set_int(ctxt, 0, a->name, a->value.i);
    case VBI_IMAGE_ATTR_FLOAT: return exr_attr_set_float(ctxt, 0, a->name, a->value.f);
    case VBI_IMAGE_ATTR_DOUBLE: return exr_attr_set_double(ctxt, 0, a->name, a->value.d);
    }
    return EXR_ERR_INVALID_ARGUMENT;
}

vbnl_result vbi_exr_write(const char *path, uint32_t width, uint32_t height,
                           const vbi_image_layer *layers, uint32_t layer_count,
                           const vbi_image_attr *attrs, uint32_t attr_count, int half_float,
                           vbnl_error *err)
{
    const uint32_t whole[4] = {0, 0, width, height};
    return vbi_exr_write_window(path, width, height, whole, layers, layer_count, attrs, attr_count,
                                 half_float, err);
}

vbnl_result vbi_exr_write_window(const char *path, uint32_t display_width, uint32_t display_height,
                                  const uint32_t window[4], const vbi_image_layer *layers,
                                  uint32_t layer_count, const vbi_image_attr *attrs,
                                  uint32_t attr_count, int half_float, vbnl_error *err)
{
    if (!window || window[0] >= window[2] || window[1] >= window[3] || window[2] > display_width ||
        window[3] > display_height || display_width > INT32_MAX || display_height > INT32_MAX)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "cannot write '%s': the data window must be a non-empty part of the "
                              "%ux%u image", path ? path : "(null)", display_width, display_height);
    const uint32_t width = window[2] - window[0], height = window[3] - window[1];
    vbnl_result r =
        vbi_exr_check_write_args(path, width, height, layers, layer_count, attrs, attr_count, err);
    if (r != VBNL_OK)
        return r;

    vbi_exr_out_channel *ch = NULL;
    uint32_t n = 0;
    int long_names = 0;
    r = vbi_exr_plan_channels(path, layers, layer_count, &ch, &n, &long_names, err);
    if (r != VBNL_OK)
        return r;
    for (uint32_t i = 0; i < attr_count; i++)
        if (strlen(attrs[i].name) > 31)
            long_names = 1;

    /* HALF: convert here (round to nearest even) and hand the encoder half data of the same
     * interleaved layout, so no library float->half path is involved. */
    const uint8_t **base = calloc(layer_count, sizeof *base);
    uint16_t **halves = half_float ? calloc(layer_count, sizeof *halves) : NULL;
    if (!base || (half_float && !halves)) {
        r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot write '%s': out of memory", path);
        goto out;
    }
    for (uint32_t i = 0; i < layer_count; i++) {
        if (!half_float) {
            base[i] = (const uint8_t *)layers[i].data;
            continue;
        }
        size_t count = (size_t)width * height * layers[i].channels;
        halves[i] = malloc(count * sizeof(uint16_t));
        if (!halves[i]) {
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot write '%s': out of memory",
                               path);
            goto out;
        }
        for (size_t j = 0; j < count; j++)
            halves[i][j] = vbi_float_to_half(layers[i].data[j]);
        base[i] = (const uint8_t *)halves[i];
    }

    vbi_atomic_file tmp;
    r = vbi_atomic_file_open(&tmp, path, err);
    if (r != VBNL_OK)
        goto out;

    vbi_exr_io io = {.fd = tmp.fd};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = vbi_exr_on_error;
    init.user_data = &io;
    init.write_fn = vbi_exr_pwrite; /* our fd: we own the temp file, fsync and rename */

    exr_context_t ctxt = NULL;
    int part = 0;
    vbi_exr_io *outer_io = vbi_exr_current_io;
    vbi_exr_current_io = &io;
    exr_result_t rv = exr_start_write(&ctxt, path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_add_part(ctxt, NULL, EXR_STORAGE_SCANLINE, &part);
    exr_attr_box2i_t display, data;
    display.min.x = 0;
    display.min.y = 0;
    display.max.x = (int32_t)display_width - 1;
    display.max.y = (int32_t)display_height - 1;
    data.min.x = (int32_t)window[0];
    data.min.y = (int32_t)window[1];
    data.max.x = (int32_t)window[2] - 1;
    data.max.y = (int32_t)window[3] - 1;
    exr_attr_v2f_t centre;
    centre.x = centre.y = 0.0f;
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr(ctxt, part, &display, &data, 1.0f, &centre, 1.0f,
                                          EXR_LINEORDER_INCREASING_Y, EXR_COMPRESSION_ZIP);
    if (rv == EXR_ERR_SUCCESS && long_names)
        rv = exr_set_longname_support(ctxt, 1);
    for (uint32_t k = 0; rv == EXR_ERR_SUCCESS && k < n; k++)
        rv = exr_add_channel(ctxt, part, ch[k].name,
                             half_float ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                             EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS) {
        /* ITU-R BT.709 primaries, D65 white: what the renderer's linear RGB means. */
        const exr_attr_chromaticities_t rec709 = {0.64f, 0.33f, 0.30f, 0.60f,
                                                  0.15f, 0.06f, 0.3127f, 0.3290f};
        rv = exr_attr_set_chromaticities(ctxt, part, "chromaticities", &rec709);
    }
    for (uint32_t i = 0; rv == EXR_ERR_SUCCESS && i < attr_count; i++)
        rv = vbi_exr_set_attr(ctxt, &attrs[i]);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(ctxt);
    if (rv == EXR_ERR_SUCCESS)
        rv = vbi_exr_write_chunks(ctxt, width, (int32_t)window[1], height, ch, n, layers, base,
                                   half_float);
    /* exr_finish writes the chunk offset table: it must run (and succeed) before the rename, and
     * must run on failure too, to free the context. */
    exr_result_t frv = exr_finish(&ctxt);
    vbi_exr_current_io = outer_io;
    if (rv == EXR_ERR_SUCCESS)
        rv = frv;
    if (rv != EXR_ERR_SUCCESS) {
        vbi_atomic_file_discard(&tmp);
        vbnl_result code = rv == EXR_ERR_OUT_OF_MEMORY ? VBNL_ERR_OUT_OF_MEMORY
                           : (rv == EXR_ERR_INVALID_ARGUMENT || rv == EXR_ERR_NAME_TOO_LONG ||
                              rv == EXR_ERR_ARGUMENT_OUT_OF_RANGE)
                               ? VBNL_ERR_INVALID_ARGUMENT
                               : VBNL_ERR_BACKEND;
        r = vbi_exr_fail(err, &io, rv, code, "write", path);
        goto out;
    }
    r = vbi_atomic_file_commit(&tmp, err);

out:
    if (halves)
        for (uint32_t i = 0; i < layer_count; i++)
            free(halves[i]);
    free(halves);
    free(base);
    free(ch);
    return r;
}

/* ---------------------------------------------------------------------------------------------- */
/* Reading                                                                                        */

void vbi_exr_image_free(vbi_exr_image *img)
{
    if (!img)
        return;
    for (uint32_t i = 0; i < img->channel_count && img->channels; i++) {
        free(img->channels[i].name);
        free(img->channels[i].data);
    }
    free(img->channels);
    for (uint32_t i = 0; i < img->attr_count && img->attrs; i++) {
        free((char *)img->attrs[i].name);
        if (img->attrs[i].type == VBI_IMAGE_ATTR_STRING)
            free((char *)img->attrs[i].value.s);
    }
    free(img->attrs);
    memset(img, 0, sizeof *img);
}

const vbi_exr_channel *vbi_exr_image_channel(const vbi_exr_image *img, const char *name)
{
    if (!img || !name)
        return NULL;
    for (uint32_t i = 0; i < img->channel_count; i++)
        if (strcmp(img->channels[i].name, name) == 0)
            return &img->channels[i];
    return NULL;
}

const vbi_image_attr *vbi_exr_image_attr(const vbi_exr_image *img, const char *name)
{
    if (!img || !name)
        return NULL;
    for (uint32_t i = 0; i < img->attr_count; i++)
        if (strcmp(img->attrs[i].name, name) == 0)
            return &img->attrs[i];
    return NULL;
}

static vbnl_result vbi_exr_read_attrs(exr_context_t ctxt, vbi_exr_image *img, const char *path,
                                       vbnl_error *err)
{
    int32_t count = 0;
    if (exr_get_attribute_count(ctxt, 0, &count) != EXR_ERR_SUCCESS || count <= 0)
        return VBNL_OK;
    img->attrs = calloc((size_t)count, sizeof *img->attrs);
    if (!img->attrs)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot read '%s': out of memory", path);
    for (int32_t i = 0; i < count; i++) {
        const exr_attribute_t *a = NULL;
        if (exr_get_attribute_by_index(ctxt, 0, EXR_ATTR_LIST_FILE_ORDER, i, &a) != EXR_ERR_SUCCESS
            || !a)
            continue;
        if (a->type == EXR_ATTR_CHROMATICITIES && strcmp(a->name, "chromaticities") == 0 &&
            a->chromaticities) {
            const exr_attr_chromaticities_t *c = a->chromaticities;
            const float v[8] = {c->red_x,  c->red_y,  c->green_x, c->green_y,
                                c->blue_x, c->blue_y, c->white_x, c->white_y};
            memcpy(img->chromaticities, v, sizeof v);
            img->has_chromaticities = 1;
            continue;
        }
        vbi_image_attr out = {0};
        switch (a->type) {
        case EXR_ATTR_STRING:
            if (!a->string)
                continue;
            out.type = VBI_IMAGE_ATTR_STRING;
            /* EXR strings carry a length and need not be NUL-terminated */
            out.value.s = strndup(a->string->str ? a->string->str : "",
                                  (size_t)(a->string->length > 0 ? a->string->length : 0));
            if (!out.value.s)
                return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY,
                                      "cannot read '%s': out of memory", path);
            break;
        case EXR_ATTR_INT: out.type = VBI_IMAGE_ATTR_INT; out.value.i = a->i; break;
        case EXR_ATTR_FLOAT: out.type = VBI_IMAGE_ATTR_FLOAT; out.value.f = a->f; break;
        case EXR_ATTR_DOUBLE: out.type = VBI_IMAGE_ATTR_DOUBLE; out.value.d = a->d; break;
        default: continue;
        }
        out.name = strdup(a->name);
        if (!out.name) {
            if (out.type == VBI_IMAGE_ATTR_STRING)
                free((char *)out.value.s);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot read '%s': out of memory",
                                  path);
        }
        img->attrs[img->attr_count++] = out;
    }
    return VBNL_OK;
}

/* Decodes one chunk planar, each channel in its stored type, into `scratch`, then converts into
 * the image. Never asks the library to convert or interleave (the 3.1 HALF->FLOAT interleaved
 * path reverses channel order). */
static exr_result_t vbi_exr_decode_chunk(exr_context_t ctxt, exr_decode_pipeline_t *dec,
                                          int *initialised, const exr_chunk_info_t *cinfo,
                                          int32_t x0, int32_t y0, vbi_exr_image *img,
                                          uint8_t **scratch, size_t *scratch_size)
{
    exr_result_t rv = *initialised ? exr_decoding_update(ctxt, 0, cinfo, dec)
                                   : exr_decoding_initialize(ctxt, 0, cinfo, dec);
    if (rv != EXR_ERR_SUCCESS)
        return rv;
    *initialised = 1;
    if (cinfo->width <= 0 || cinfo->height <= 0 || x0 < 0 || y0 < 0 ||
        (uint32_t)x0 + (uint32_t)cinfo->width > img->width ||
        (uint32_t)y0 + (uint32_t)cinfo->height > img->height ||
        (uint32_t)dec->channel_count != img->channel_count)
        return EXR_ERR_CORRUPT_CHUNK;

    size_t pixels = (size_t)cinfo->width * (size_t)cinfo->height;
    size_t need = pixels * 4u * img->channel_count;
    if (need > *scratch_size) {
        uint8_t *s = realloc(*scratch, need);
        if (!s)
            return EXR_ERR_OUT_OF_MEMORY;
        *scratch = s;
        *scratch_size = need;
    }
    for (int16_t c = 0; c < dec->channel_count; c++) {
        exr_coding_channel_info_t *dc = &dec->channels[c];
        dc->user_bytes_per_element = dc->bytes_per_element;
        dc->user_data_type = dc->data_type;
        dc->user_pixel_stride = dc->bytes_per_element;
        dc->user_line_stride = cinfo->width * dc->bytes_per_element;
        dc->decode_to_ptr = *scratch + (size_t)c * pixels * 4u;
    }
    rv = exr_decoding_choose_default_routines(ctxt, 0, dec);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_decoding_run(ctxt, 0, dec);
    if (rv != EXR_ERR_SUCCESS)
        return rv;

    for (int16_t c = 0; c < dec->channel_count; c++) {
        const exr_coding_channel_info_t *dc = &dec->channels[c];
        /* decoder channel c is file channel c, but look it up by name all the same */
        vbi_exr_channel *oc = NULL;
        if (strcmp(img->channels[c].name, dc->channel_name) == 0)
            oc = &img->channels[c];
        for (uint32_t k = 0; k < img->channel_count && !oc; k++)
            if (strcmp(img->channels[k].name, dc->channel_name) == 0)
                oc = &img->channels[k];
        if (!oc)
            return EXR_ERR_INCORRECT_CHUNK;
        const uint8_t *src = *scratch + (size_t)c * pixels * 4u;
        for (int32_t y = 0; y < cinfo->height; y++) {
            float *dst = oc->data + (size_t)(y0 + y) * img->width + (size_t)x0;
            for (int32_t x = 0; x < cinfo->width; x++) {
                size_t i = (size_t)y * (size_t)cinfo->width + (size_t)x;
                if (dc->data_type == EXR_PIXEL_HALF) {
                    uint16_t h;
                    memcpy(&h, src + i * 2u, 2);
                    dst[x] = vbi_half_to_float(h);
                } else if (dc->data_type == EXR_PIXEL_FLOAT) {
                    memcpy(&dst[x], src + i * 4u, 4);
                } else {
                    uint32_t u;
                    memcpy(&u, src + i * 4u, 4);
                    dst[x] = (float)u;
                }
            }
        }
    }
    return EXR_ERR_SUCCESS;
}

static exr_result_t vbi_exr_read_pixels(exr_context_t ctxt, exr_storage_t storage,
                                         exr_attr_box2i_t dw, vbi_exr_image *img)
{
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialised = 0;
    uint8_t *scratch = NULL;
    size_t scratch_size = 0;
    exr_result_t rv = EXR_ERR_SUCCESS;
    exr_chunk_info_t cinfo;

    if (storage == EXR_STORAGE_SCANLINE) {
        int32_t lines = 1;
        rv = exr_get_scanlines_per_chunk(ctxt, 0, &lines);
        if (rv == EXR_ERR_SUCCESS && lines <= 0)
            rv = EXR_ERR_FILE_BAD_HEADER;
        for (int64_t y = dw.min.y; rv == EXR_ERR_SUCCESS && y <= dw.max.y; y += lines) {
            rv = exr_read_scanline_chunk_info(ctxt, 0, (int)y, &cinfo);
            if (rv == EXR_ERR_SUCCESS)
                rv = vbi_exr_decode_chunk(ctxt, &dec, &initialised, &cinfo, 0,
                                           (int32_t)(cinfo.start_y - dw.min.y), img, &scratch,
                                           &scratch_size);
        }
    } else {
        uint32_t tw = 0, th = 0;
        exr_tile_level_mode_t level;
        exr_tile_round_mode_t round;
        rv = exr_get_tile_descriptor(ctxt, 0, &tw, &th, &level, &round);
        if (rv == EXR_ERR_SUCCESS && (tw == 0 || th == 0))
            rv = EXR_ERR_FILE_BAD_HEADER;
        uint32_t ntx = rv == EXR_ERR_SUCCESS ? (img->width + tw - 1) / tw : 0;
        uint32_t nty = rv == EXR_ERR_SUCCESS ? (img->height + th - 1) / th : 0;
        for (uint32_t ty = 0; rv == EXR_ERR_SUCCESS && ty < nty; ty++) {
            for (uint32_t tx = 0; rv == EXR_ERR_SUCCESS && tx < ntx; tx++) {
                rv = exr_read_tile_chunk_info(ctxt, 0, (int)tx, (int)ty, 0, 0, &cinfo);
                /* the chunk's start_x/start_y are tile indices here: use our own origin */
                if (rv == EXR_ERR_SUCCESS)
                    rv = vbi_exr_decode_chunk(ctxt, &dec, &initialised, &cinfo,
                                               (int32_t)(tx * tw), (int32_t)(ty * th), img,
                                               &scratch, &scratch_size);
            }
        }
    }
    if (initialised)
        exr_decoding_destroy(ctxt, &dec);
    free(scratch);
    return rv;
}

vbnl_result vbi_exr_read(const char *path, vbi_exr_image *out, vbnl_error *err)
{
    if (out)
        memset(out, 0, sizeof *out);
    if (!path || !out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "cannot read EXR: %s is NULL", !path ? "path" : "out");

    vbi_exr_io io = {.fd = -1};
    struct stat st;
    const char *why;
    if ((io.fd = vbi_read_open(path, &st, &why)) < 0)
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot read '%s': %s", path, why);
    io.size = (int64_t)st.st_size;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = vbi_exr_on_error;
    init.user_data = &io;
    init.read_fn = vbi_exr_pread;
    init.size_fn = vbi_exr_size;

    exr_context_t ctxt = NULL;
    vbi_exr_io *outer_io = vbi_exr_current_io;
    vbi_exr_current_io = &io;
    exr_result_t rv = exr_start_read(&ctxt, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        /* a short read is a file that ends early (damage); only a failed read is an I/O error */
        vbnl_result code = rv == EXR_ERR_FILE_ACCESS || io.read_errno ? VBNL_ERR_IO
                           : rv == EXR_ERR_OUT_OF_MEMORY              ? VBNL_ERR_OUT_OF_MEMORY
                                                                      : VBNL_ERR_CORRUPT;
        exr_finish(&ctxt);
        close(io.fd);
        vbi_exr_current_io = outer_io;
        return vbi_exr_fail(err, &io, rv, code, "read", path);
    }

    vbi_exr_image img = {0};
    vbnl_result r = VBNL_OK;
    exr_storage_t storage = EXR_STORAGE_SCANLINE;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    rv = exr_get_storage(ctxt, 0, &storage);
    exr_attr_box2i_t disp;
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_data_window(ctxt, 0, &dw);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_display_window(ctxt, 0, &disp);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_channels(ctxt, 0, &chl);
    if (rv != EXR_ERR_SUCCESS || !chl) {
        r = vbi_exr_fail(err, &io, rv ? rv : EXR_ERR_MISSING_REQ_ATTR, VBNL_ERR_CORRUPT, "read",
                          path);
        goto done;
    }
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED) {
        r = vbnl_error_set(err, VBNL_ERR_UNSUPPORTED, "cannot read '%s': deep images are not "
                           "supported", path);
        goto done;
    }
    int64_t w = (int64_t)dw.max.x - dw.min.x + 1, h = (int64_t)dw.max.y - dw.min.y + 1;
    if (w <= 0 || h <= 0 || w > INT32_MAX || h > INT32_MAX || chl->num_channels <= 0) {
        r = vbnl_error_set(err, VBNL_ERR_CORRUPT, "cannot read '%s': bad data window or no "
                           "channels", path);
        goto done;
    }
    img.width = (uint32_t)w;
    img.height = (uint32_t)h;
    img.data_x = dw.min.x;
    img.data_y = dw.min.y;
    int64_t dsw = (int64_t)disp.max.x - disp.min.x + 1, dsh = (int64_t)disp.max.y - disp.min.y + 1;
    if (dsw <= 0 || dsh <= 0 || dsw > INT32_MAX || dsh > INT32_MAX) {
        r = vbnl_error_set(err, VBNL_ERR_CORRUPT, "cannot read '%s': bad display window", path);
        goto done;
    }
    img.display_x = disp.min.x;
    img.display_y = disp.min.y;
    img.display_width = (uint32_t)dsw;
    img.display_height = (uint32_t)dsh;
    if ((size_t)w > SIZE_MAX / sizeof(float) / (size_t)h) {
        r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot read '%s': image too large", path);
        goto done;
    }
    img.channels = calloc((size_t)chl->num_channels, sizeof *img.channels);
    if (!img.channels) {
        r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot read '%s': out of memory", path);
        goto done;
    }
    for (int c = 0; c < chl->num_channels; c++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[c];
        if (e->x_sampling != 1 || e->y_sampling != 1) {
            r = vbnl_error_set(err, VBNL_ERR_UNSUPPORTED, "cannot read '%s': channel '%.*s' is "
                               "subsampled", path, e->name.length, e->name.str);
            goto done;
        }
        vbi_exr_channel *oc = &img.channels[img.channel_count++];
        oc->name = strndup(e->name.str, (size_t)e->name.length);
        oc->stored_type = (vbi_exr_pixel_type)e->pixel_type;
        oc->data = calloc((size_t)w * (size_t)h, sizeof(float));
        if (!oc->name || !oc->data) {
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot read '%s': out of memory",
                               path);
            goto done;
        }
    }
    r = vbi_exr_read_attrs(ctxt, &img, path, err);
    if (r != VBNL_OK)
        goto done;
    rv = vbi_exr_read_pixels(ctxt, storage, dw, &img);
    if (rv != EXR_ERR_SUCCESS) {
        r = vbi_exr_fail(err, &io, rv,
                          rv == EXR_ERR_OUT_OF_MEMORY ? VBNL_ERR_OUT_OF_MEMORY : VBNL_ERR_CORRUPT,
                          "read", path);
        goto done;
    }

done:
    exr_finish(&ctxt);
    close(io.fd);
    vbi_exr_current_io = outer_io;
    if (r != VBNL_OK) {
        vbi_exr_image_free(&img);
        return r;
    }
    *out = img;
    return VBNL_OK;
}
