/* vbnl: libFuzzer target for mesh import (assimp behind vbnl_mesh_import).
 *
 * The input's first byte picks the format (PLY, OBJ, glTF, OFF, STL), the rest is written to a
 * file of that extension in a private folder and imported into a scene that is not committed:
 * what a mesh file from anyone reaches. tools/fuzz.sh builds and runs it beside the scene-parser
 * target, seeded with the examples' meshes and small files of each format. */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "vbnl/mesh_import.h"
#include "vbnl/render.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static vbnl_context *ctx;
static char dir[64];

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const ext[] = {"ply", "obj", "gltf", "off", "stl"};
    if (!ctx) {
        vbnl_context_desc cd;
        vbnl_context_desc_init(&cd);
        cd.threads = 1;
        snprintf(dir, sizeof(dir), "/tmp/vbnl_fuzz_mesh_XXXXXX");
        if (vbnl_context_create(&cd, &ctx, NULL) != VBNL_OK || !mkdtemp(dir))
            return 0;
    }
    if (size < 1)
        return 0;
    char path[128];
    snprintf(path, sizeof(path), "%s/m.%s", dir, ext[data[0] % 5]);
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    fwrite(data + 1, 1, size - 1, f);
    fclose(f);
    vbnl_scene *s = NULL;
    if (vbnl_scene_create(ctx, &s, NULL) == VBNL_OK)
        vbnl_mesh_import(s, path, NULL, NULL, NULL);
    vbnl_scene_destroy(s);
    unlink(path);
    return 0;
}
