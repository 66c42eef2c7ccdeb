/* Mesh import through assimp's C API. A mesh file is untrusted input: assimp reads only through
 * the file functions below, which open nothing outside the mesh file's folder (an OBJ's mtllib,
 * a glTF's buffers and images), the imported data are validated before any other step uses
 * them, and a PLY file must hold exactly the elements its header declares (ply_check.h). */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <assimp/cfileio.h>
#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "vbnl/mesh_import.h"
#include "ply_check.h"
#include "read_file.h"

float vbnl_phong_exponent_to_alpha(float ns)
{
    if (!(ns >= 0.0f))
        ns = 0.0f;
    float a = sqrtf(2.0f / (ns + 2.0f));
    return a < 0.001f ? 0.001f : (a > 1.0f ? 1.0f : a);
}

static float clamp01(float v) { return v < 0.0f ? 0.0f : (v > 1.0f ? 1.0f : v); }

/* AI_MATKEY_* expand to (key, type, index). */
static int get_color(const struct aiMaterial *m, const char *key, unsigned type, unsigned index, float out[3])
{
    struct aiColor4D c;
    if (aiGetMaterialColor(m, key, type, index, &c) != AI_SUCCESS)
        return 0;
    out[0] = c.r;
    out[1] = c.g;
    out[2] = c.b;
    return 1;
}

static float max3(const float v[3]) { return fmaxf(v[0], fmaxf(v[1], v[2])); }

/* The MTL -> material rule documented in mesh_import.h. */
static void map_material(const struct aiMaterial *m, int two_sided, vbnl_material_desc *d, int *emissive)
{
    float kd[3] = {0.8f, 0.8f, 0.8f}, ks[3] = {0, 0, 0}, ke[3] = {0, 0, 0}, tf[3] = {1, 1, 1};
    float ns = 0.0f, ni = 1.0f, opacity = 1.0f;
    int illum = 2;
    get_color(m, AI_MATKEY_COLOR_DIFFUSE, kd);
    get_color(m, AI_MATKEY_COLOR_SPECULAR, ks);
    get_color(m, AI_MATKEY_COLOR_EMISSIVE, ke);
    get_color(m, AI_MATKEY_COLOR_TRANSPARENT, tf);
    aiGetMaterialFloatArray(m, AI_MATKEY_SHININESS, &ns, NULL);
    aiGetMaterialFloatArray(m, AI_MATKEY_REFRACTI, &ni, NULL);
    aiGetMaterialFloatArray(m, AI_MATKEY_OPACITY, &opacity, NULL);
    /* MTL illum: assimp keeps the raw value under "$mat.illum" */
    int raw_illum;
    unsigned one = 1;
    if (aiGetMaterialIntegerArray(m, "$mat.illum", 0, 0, &raw_illum, &one) == AI_SUCCESS)
        illum = raw_illum;
    vbnl_material_desc_init(d);
    float ior = ni > 1.0f ? ni : 1.5f;
    if (illum == 4 || illum == 6 || illum == 7 || illum == 9 || opacity < 1.0f) {
        d->type = VBNL_MATERIAL_DIELECTRIC;
        for (int i = 0; i < 3; ++i)
            d->base_color[i] = clamp01(tf[i]);
        d->ior = ior;
    } else if ((illum == 3 || illum == 5) && max3(ks) > 0.0f) {
        d->type = VBNL_MATERIAL_MIRROR;
        for (int i = 0; i < 3; ++i)
            d->base_color[i] = clamp01(ks[i]);
    } else if (max3(ks) > 0.0f && max3(kd) > 0.0f) {
        d->type = VBNL_MATERIAL_PLASTIC;
        for (int i = 0; i < 3; ++i)
            d->base_color[i] = clamp01(kd[i]);
        d->alpha = vbnl_phong_exponent_to_alpha(ns);
        d->ior = ior;
    } else if (max3(ks) > 0.0f) {
        d->type = VBNL_MATERIAL_CONDUCTOR;
        for (int i = 0; i < 3; ++i)
            d->base_color[i] = clamp01(ks[i]);
        d->alpha = vbnl_phong_exponent_to_alpha(ns);
    } else {
        d->type = VBNL_MATERIAL_LAMBERT;
        for (int i = 0; i < 3; ++i)
            d->base_color[i] = clamp01(kd[i]);
    }
    for (int i = 0; i < 3; ++i)
        d->emission[i] = ke[i] > 0.0f && isfinite(ke[i]) ? ke[i] : 0.0f;
    d->two_sided = two_sided;
    *emissive = max3(d->emission) > 0.0f;
}

/* ---- files: what assimp may open ---------------------------------------------------------------- */

typedef struct mesh_io {
    char dir[PATH_MAX];      /* the canonical folder of the mesh file */
    char refused[PATH_MAX];  /* the first file asked for outside it, or "" */
} mesh_io;

static FILE *io_fp(struct aiFile *f) { return (FILE *)(void *)f->UserData; }
static size_t io_read(struct aiFile *f, char *buf, size_t size, size_t count) { return fread(buf, size, count, io_fp(f)); }
static size_t io_write(struct aiFile *f, const char *buf, size_t size, size_t count)
{
    (void)f;
    (void)buf;
    (void)size;
    (void)count;
    return 0; /* import never writes */
}
static size_t io_tell(struct aiFile *f)
{
    long t = ftell(io_fp(f));
    return t < 0 ? 0 : (size_t)t;
}
static size_t io_size(struct aiFile *f)
{
    struct stat st;
    return fstat(fileno(io_fp(f)), &st) == 0 ? (size_t)st.st_size : 0;
}
static enum aiReturn io_seek(struct aiFile *f, size_t off, enum aiOrigin origin)
{
    int whence = origin == aiOrigin_SET ? SEEK_SET : origin == aiOrigin_CUR ? SEEK_CUR : SEEK_END;
    return fseek(io_fp(f), (long)off, whence) == 0 ? aiReturn_SUCCESS : aiReturn_FAILURE;
}
static void io_flush(struct aiFile *f) { (void)f; }

static int io_inside(const char *dir, const char *path)
{
    size_t n = strlen(dir);
    return !strncmp(path, dir, n) && (path[n] == '/' || (n == 1 && dir[0] == '/'));
}

static struct aiFile *io_open(struct aiFileIO *io, const char *name, const char *mode)
{
    mesh_io *m = (mesh_io *)(void *)io->UserData;
    if (strpbrk(mode, "wa+"))
        return NULL;
    char real[PATH_MAX];
    if (!realpath(name, real))
        return NULL; /* absent: the importer says what it missed */
    if (!io_inside(m->dir, real)) {
        if (!m->refused[0])
            snprintf(m->refused, sizeof(m->refused), "%s", name);
        return NULL;
    }
    const char *why;
    FILE *fp = vbi_read_fopen(real, NULL, &why); /* a FIFO beside the file is refused, not waited on */
    struct aiFile *f = fp ? calloc(1, sizeof(*f)) : NULL;
    if (!f) {
        if (fp)
            fclose(fp);
        return NULL;
    }
    f->ReadProc = io_read;
    f->WriteProc = io_write;
    f->TellProc = io_tell;
    f->FileSizeProc = io_size;
    f->SeekProc = io_seek;
    f->FlushProc = io_flush;
    f->UserData = (aiUserData)(void *)fp;
    return f;
}

static void io_close(struct aiFileIO *io, struct aiFile *f)
{
    (void)io;
    if (f) {
        fclose(io_fp(f));
        free(f);
    }
}

/* Why an OBJ file assimp could not import (or that gave no triangle) looks truncated, or NULL:
 * assimp's own words for a file cut short ("Mesh contains no faces", "aiScene::mNumMeshes is 0",
 * "all meshes are orphaned", "mFaces[1] is a LINE") do not say so. `why` holds the reason: no face
 * statement in the file, or a last line without its newline. */
static const char *obj_truncation(const char *path, char *why, size_t n)
{
    size_t len = strlen(path);
    if (len < 4 || strcasecmp(path + len - 4, ".obj") != 0)
        return NULL;
    const char *no;
    FILE *f = vbi_read_fopen(path, NULL, &no);
    if (!f)
        return NULL;
    /* a face statement: 'f' and a blank first on a line (blanks before it allowed) */
    enum { AT_START, AFTER_F, IN_LINE } state = AT_START;
    unsigned long long faces = 0, lines = 1;
    int c, last = '\n';
    while ((c = getc(f)) != EOF) {
        if (c == '\n') {
            state = AT_START;
            ++lines;
        } else if (state == AT_START && c == 'f') {
            state = AFTER_F;
        } else if (state == AFTER_F) {
            faces += c == ' ' || c == '\t';
            state = IN_LINE;
        } else if (state == AT_START && c != ' ' && c != '\t' && c != '\r') {
            state = IN_LINE;
        }
        last = c;
    }
    fclose(f);
    if (faces == 0)
        snprintf(why, n, "no faces in it: truncated or empty OBJ?");
    else if (last != '\n')
        snprintf(why, n, "its last line (line %llu) ends without a newline: truncated OBJ?", lines);
    else
        return NULL;
    return why;
}

vbnl_result vbnl_mesh_import(vbnl_scene *scene, const char *path, const vbnl_mesh_import_options *opt,
                             vbnl_mesh_import_stats *stats, vbnl_error *err)
{
    if (!scene || !path)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_mesh_import: NULL argument");
    vbnl_mesh_import_options defaults;
    memset(&defaults, 0, sizeof(defaults));
    if (!opt)
        opt = &defaults;
    /* the file itself: a regular file (read_file.h), a PLY file checked against its header */
    struct stat fst;
    const char *no;
    FILE *fp = vbi_read_fopen(path, &fst, &no);
    if (!fp)
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot import '%s': %s", path, no);
    char why[160];
    const char *bad = mesh_ply_check(fp, (uint64_t)fst.st_size, why, sizeof(why));
    fclose(fp);
    if (bad)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "cannot import '%s': %s", path, bad);
    mesh_io m;
    m.refused[0] = '\0';
    /* the folder of the file itself (a link named by the user leads to its file's folder) */
    if (!realpath(path, m.dir))
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot import '%s': %s", path, strerror(errno));
    *(strrchr(m.dir, '/') == m.dir ? m.dir + 1 : strrchr(m.dir, '/')) = '\0';
    struct aiFileIO io = {io_open, io_close, (aiUserData)(void *)&m};
    /* ValidateDataStructure runs first: an index past the vertices is an error, not a read
     * outside the arrays by the steps after it. */
    const struct aiScene *ai =
        aiImportFileEx(path,
                       aiProcess_ValidateDataStructure | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                           aiProcess_PreTransformVertices | aiProcess_SortByPType,
                       &io);
    if (m.refused[0]) {
        if (ai)
            aiReleaseImport(ai);
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "cannot import '%s': it names '%s', outside its folder (a mesh file reads only the "
                              "files beside it)",
                              path, m.refused);
    }
    if (!ai) {
        char cut[128];
        if (obj_truncation(path, cut, sizeof(cut)))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "cannot import '%s': %s (assimp: %s)", path, cut,
                                  aiGetErrorString());
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot import '%s': %s", path, aiGetErrorString());
    }
    vbnl_result r = VBNL_OK;
    uint32_t *mat_ids = NULL;
    vbnl_mesh_import_stats st;
    memset(&st, 0, sizeof(st));
    if (!opt->override_material) {
        mat_ids = calloc(ai->mNumMaterials ? ai->mNumMaterials : 1, sizeof(uint32_t));
        if (!mat_ids) {
            aiReleaseImport(ai);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        for (unsigned i = 0; i < ai->mNumMaterials; ++i) {
            vbnl_material_desc d;
            int emissive;
            map_material(ai->mMaterials[i], opt->two_sided_emission, &d, &emissive);
            if ((r = vbnl_scene_add_material(scene, &d, &mat_ids[i], err)) != VBNL_OK)
                goto done;
            st.materials++;
            st.emissive_materials += (uint32_t)emissive;
        }
    }
    for (unsigned mi = 0; mi < ai->mNumMeshes; ++mi) {
        const struct aiMesh *am = ai->mMeshes[mi];
        /* after triangulation the NGON flag may be set too: mask it */
        unsigned types = am->mPrimitiveTypes & ~(unsigned)aiPrimitiveType_NGONEncodingFlag;
        if (!(types & aiPrimitiveType_TRIANGLE) || am->mNumVertices == 0)
            continue; /* points and lines carry no surface */
        uint32_t ntri = 0;
        for (unsigned f = 0; f < am->mNumFaces; ++f)
            ntri += am->mFaces[f].mNumIndices == 3;
        if (ntri == 0)
            continue;
        float *pos = malloc(sizeof(float) * 3 * am->mNumVertices);
        float *nrm = am->mNormals ? malloc(sizeof(float) * 3 * am->mNumVertices) : NULL;
        float *uv = am->mTextureCoords[0] ? malloc(sizeof(float) * 2 * am->mNumVertices) : NULL;
        uint32_t *idx = malloc(sizeof(uint32_t) * 3 * ntri);
        if (!pos || !idx || (am->mNormals && !nrm) || (am->mTextureCoords[0] && !uv)) {
            free(pos);
            free(nrm);
            free(uv);
            free(idx);
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory importing '%s'", path);
            goto done;
        }
        for (unsigned v = 0; v < am->mNumVertices; ++v) {
            pos[3 * v] = am->mVertices[v].x;
            pos[3 * v + 1] = am->mVertices[v].y;
            pos[3 * v + 2] = am->mVertices[v].z;
            if (nrm) {
                nrm[3 * v] = am->mNormals[v].x;
                nrm[3 * v + 1] = am->mNormals[v].y;
                nrm[3 * v + 2] = am->mNormals[v].z;
            }
            if (uv) {
                uv[2 * v] = am->mTextureCoords[0][v].x;
                uv[2 * v + 1] = am->mTextureCoords[0][v].y;
            }
        }
        uint32_t k = 0;
        for (unsigned f = 0; f < am->mNumFaces; ++f) {
            if (am->mFaces[f].mNumIndices != 3)
                continue;
            idx[3 * k] = am->mFaces[f].mIndices[0];
            idx[3 * k + 1] = am->mFaces[f].mIndices[1];
            idx[3 * k + 2] = am->mFaces[f].mIndices[2];
            ++k;
        }
        vbnl_mesh_desc md;
        vbnl_mesh_desc_init(&md);
        md.positions = pos;
        md.normals = nrm;
        md.uvs = uv;
        md.vertex_count = am->mNumVertices;
        md.indices = idx;
        md.triangle_count = ntri;
        md.material = opt->override_material ? opt->material
                                             : (am->mMaterialIndex < ai->mNumMaterials ? mat_ids[am->mMaterialIndex] : 0);
        md.transform = opt->transform;
        md.group = opt->group;
        r = vbnl_scene_add_mesh(scene, &md, NULL, err);
        free(pos);
        free(nrm);
        free(uv);
        free(idx);
        if (r != VBNL_OK) {
            char inner[VBNL_ERROR_MESSAGE_SIZE];
            strcpy(inner, err ? err->message : "");
            vbnl_error_set(err, r, "'%s', mesh %u: %s", path, mi, inner);
            goto done;
        }
        st.meshes++;
        st.triangles += ntri;
    }
    if (st.triangles == 0) {
        char cut[128];
        if (obj_truncation(path, cut, sizeof(cut)))
            r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "cannot import '%s': %s", path, cut);
        else
            r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "'%s' contains no triangles", path);
    }
done:
    free(mat_ids);
    aiReleaseImport(ai);
    if (stats)
        *stats = st;
    return r;
}
