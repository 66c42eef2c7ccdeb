/* POV-Ray 3.7's render options: .ini files, +/- switches and KEY=VALUE (pov_options.h). The
 * syntax follows POV-Ray 3.7's reference ("Command-line and INI-file options", "Using INI
 * files"): keys and switches in any case; in .ini files ';' starts a comment, [Section] lines
 * start sections that are read only when the file is named as FILE.ini[Section], values may be
 * quoted with ' or " and several values of one key separated by commas; a line may hold switches;
 * a bare file name is an .ini file read where it stands, a .pov file the scene, a name ending in
 * '/' a library folder. */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "pov_options.h"
#include "read_file.h"

/* What a key or switch does. The kinds after NOTE only note that they do not apply. */
typedef enum {
    K_INPUT, K_OUTPUT, K_WIDTH, K_HEIGHT, K_START_COL, K_START_ROW, K_END_COL, K_END_ROW, K_FILE_TYPE, K_BITS,
    K_ALPHA, K_OUTPUT_TO_FILE, K_LIBRARY, K_DECLARE, K_INCLUDE_INI, K_INITIAL_FRAME, K_FINAL_FRAME,
    K_INITIAL_CLOCK, K_FINAL_CLOCK, K_CLOCK, K_SUBSET_START, K_SUBSET_END, K_CYCLIC, K_FRAME_STEP, K_ALL_FILE,
    K_APPEND_FILE, K_ALL_CONSOLE, K_RENDER_CONSOLE, K_VERBOSE, K_THREADS, K_VERSION, K_DITHER,
    K_NOTE,           /* any value: one note */
    K_NOTE_WHEN_ON,   /* a boolean: one note when on (off asks for what vbnl does anyway) */
    K_NOTE_WHEN_OFF,  /* a boolean: one note when off */
} pov_kind;

typedef enum { V_NONE, V_BOOL, V_INT, V_FLOAT, V_STRING } pov_value;

typedef struct key_row {
    const char *key;
    pov_kind kind;
    pov_value value;
    const char *why; /* the note of the NOTE kinds */
} key_row;

#define AA "vbnl takes --spp samples in every pixel (box filter) instead of POV-Ray's adaptive antialiasing"
#define BOUNDS "Embree builds vbnl's acceleration structures"
#define STREAM "vbnl prints every message on the console and, with All_File, into one file"
#define SHELL "vbnl runs no shell-out commands"
#define GAMMA "the PNG goes through the OpenColorIO view (--display, --view; default sRGB, Standard), the EXR is scene-linear"
#define RAD "vbnl computes global illumination with its integrators (--integrator)"
#define BLOCKS "vbnl renders in tiles of its own"
#define PREVIEW "vbnl shows no preview window"

/* POV-Ray 3.7's .ini keys (reference "Options Index"), and Antialias_Confidence of UberPOV, which
 * Blender's exporter writes for it. */
static const key_row keys[] = {
    {"All_Console", K_ALL_CONSOLE, V_BOOL, NULL},
    {"All_File", K_ALL_FILE, V_STRING, NULL},
    {"Antialias", K_NOTE_WHEN_ON, V_BOOL, AA},
    {"Antialias_Confidence", K_NOTE, V_FLOAT, AA},
    {"Antialias_Depth", K_NOTE, V_INT, AA},
    {"Antialias_Gamma", K_NOTE, V_FLOAT, AA},
    {"Antialias_Threshold", K_NOTE, V_FLOAT, AA},
    {"Append_File", K_APPEND_FILE, V_BOOL, NULL},
    {"Bits_Per_Color", K_BITS, V_INT, NULL},
    {"Bits_Per_Colour", K_BITS, V_INT, NULL},
    {"Bounding", K_NOTE_WHEN_OFF, V_BOOL, BOUNDS},
    {"Bounding_Method", K_NOTE, V_INT, BOUNDS},
    {"Bounding_Threshold", K_NOTE, V_INT, BOUNDS},
    {"BSP_BaseAccessCost", K_NOTE, V_FLOAT, BOUNDS},
    {"BSP_ChildAccessCost", K_NOTE, V_FLOAT, BOUNDS},
    {"BSP_ISectCost", K_NOTE, V_FLOAT, BOUNDS},
    {"BSP_MaxDepth", K_NOTE, V_INT, BOUNDS},
    {"BSP_MissChance", K_NOTE, V_FLOAT, BOUNDS},
    {"Buffer_Output", K_NOTE, V_STRING, "no longer used by POV-Ray 3.7"},
    {"Buffer_Size", K_NOTE, V_STRING, "no longer used by POV-Ray 3.7"},
    {"Clock", K_CLOCK, V_FLOAT, NULL},
    {"Clockless_Animation", K_NOTE_WHEN_ON, V_BOOL, "vbnl animates with the clock only"},
    {"Compression", K_NOTE, V_INT, "vbnl writes PNG and ZIP-compressed OpenEXR"},
    {"Continue_Trace", K_NOTE_WHEN_ON, V_BOOL, "vbnl renders the whole image again"},
    {"Create_Histogram", K_NOTE, V_STRING, "vbnl writes no histogram"},
    {"Create_Ini", K_NOTE, V_STRING, "vbnl writes no .ini file"},
    {"Cyclic_Animation", K_CYCLIC, V_BOOL, NULL},
    {"Debug_Console", K_NOTE_WHEN_OFF, V_BOOL, STREAM},
    {"Debug_File", K_NOTE, V_STRING, STREAM},
    {"Declare", K_DECLARE, V_STRING, NULL},
    {"Display", K_NOTE_WHEN_ON, V_BOOL, PREVIEW},
    {"Display_Gamma", K_NOTE, V_STRING, GAMMA},
    {"Dither", K_DITHER, V_BOOL, NULL},
    {"Dither_Method", K_NOTE, V_STRING, "vbnl dithers its PNG with triangular noise"},
    {"Draw_Vistas", K_NOTE_WHEN_ON, V_BOOL, PREVIEW},
    {"End_Column", K_END_COL, V_FLOAT, NULL},
    {"End_Row", K_END_ROW, V_FLOAT, NULL},
    {"Fatal_Console", K_NOTE_WHEN_OFF, V_BOOL, STREAM},
    {"Fatal_Error_Command", K_NOTE, V_STRING, SHELL},
    {"Fatal_Error_Return", K_NOTE, V_STRING, SHELL},
    {"Fatal_File", K_NOTE, V_STRING, STREAM},
    {"Field_Render", K_NOTE_WHEN_ON, V_BOOL, "vbnl renders whole frames"},
    {"File_Gamma", K_NOTE, V_STRING, GAMMA},
    {"Final_Clock", K_FINAL_CLOCK, V_FLOAT, NULL},
    {"Final_Frame", K_FINAL_FRAME, V_INT, NULL},
    {"Frame_Step", K_FRAME_STEP, V_INT, NULL},
    {"Grayscale_Output", K_NOTE_WHEN_ON, V_BOOL, "vbnl writes colour images"},
    {"Height", K_HEIGHT, V_INT, NULL},
    {"High_Reproducibility", K_NOTE, V_BOOL, "vbnl gives the same image for a seed (--seed) on any thread count"},
    {"Histogram_Grid_Size", K_NOTE, V_STRING, "vbnl writes no histogram"},
    {"Histogram_Name", K_NOTE, V_STRING, "vbnl writes no histogram"},
    {"Histogram_Type", K_NOTE, V_STRING, "vbnl writes no histogram"},
    {"Include_Header", K_NOTE, V_STRING, "vbnl includes no header file; #include it in the scene"},
    {"Include_Ini", K_INCLUDE_INI, V_STRING, NULL},
    {"Initial_Clock", K_INITIAL_CLOCK, V_FLOAT, NULL},
    {"Initial_Frame", K_INITIAL_FRAME, V_INT, NULL},
    {"Input_File_Name", K_INPUT, V_STRING, NULL},
    {"Jitter", K_NOTE_WHEN_ON, V_BOOL, AA},
    {"Jitter_Amount", K_NOTE, V_FLOAT, AA},
    {"Library_Path", K_LIBRARY, V_STRING, NULL},
    {"Light_Buffer", K_NOTE_WHEN_ON, V_BOOL, BOUNDS},
    {"Max_Image_Buffer_Memory", K_NOTE, V_INT, "vbnl keeps its image in memory"},
    {"Odd_Field", K_NOTE_WHEN_ON, V_BOOL, "vbnl renders whole frames"},
    {"Output_Alpha", K_ALPHA, V_BOOL, NULL},
    {"Output_File_Name", K_OUTPUT, V_STRING, NULL},
    {"Output_File_Type", K_FILE_TYPE, V_STRING, NULL},
    {"Output_To_File", K_OUTPUT_TO_FILE, V_BOOL, NULL},
    {"Palette", K_NOTE, V_STRING, PREVIEW},
    {"Pause_When_Done", K_NOTE_WHEN_ON, V_BOOL, "vbnl exits when the image is written"},
    {"Post_Frame_Command", K_NOTE, V_STRING, SHELL},
    {"Post_Frame_Return", K_NOTE, V_STRING, SHELL},
    {"Post_Scene_Command", K_NOTE, V_STRING, SHELL},
    {"Post_Scene_Return", K_NOTE, V_STRING, SHELL},
    {"Pre_Frame_Command", K_NOTE, V_STRING, SHELL},
    {"Pre_Frame_Return", K_NOTE, V_STRING, SHELL},
    {"Pre_Scene_Command", K_NOTE, V_STRING, SHELL},
    {"Pre_Scene_Return", K_NOTE, V_STRING, SHELL},
    {"Preview_End_Size", K_NOTE, V_INT, PREVIEW},
    {"Preview_Start_Size", K_NOTE, V_INT, PREVIEW},
    {"Quality", K_NOTE, V_INT, "vbnl renders every feature it maps, with global illumination, at any quality"},
    {"Radiosity_File_Name", K_NOTE, V_STRING, RAD},
    {"Radiosity_From_File", K_NOTE_WHEN_ON, V_BOOL, RAD},
    {"Radiosity_To_File", K_NOTE_WHEN_ON, V_BOOL, RAD},
    {"Radiosity_Vain_Pretrace", K_NOTE, V_BOOL, RAD},
    {"Real_Time_Raytracing", K_NOTE_WHEN_ON, V_BOOL, PREVIEW},
    {"Remove_Bounds", K_NOTE, V_BOOL, BOUNDS},
    {"Render_Block_Size", K_NOTE, V_INT, BLOCKS},
    {"Render_Block_Step", K_NOTE, V_INT, BLOCKS},
    {"Render_Console", K_RENDER_CONSOLE, V_BOOL, NULL},
    {"Render_File", K_NOTE, V_STRING, STREAM},
    {"Render_Pattern", K_NOTE, V_INT, BLOCKS},
    {"Sampling_Method", K_NOTE, V_INT, AA},
    {"Split_Unions", K_NOTE_WHEN_ON, V_BOOL, BOUNDS},
    {"Start_Column", K_START_COL, V_FLOAT, NULL},
    {"Start_Row", K_START_ROW, V_FLOAT, NULL},
    {"Statistic_Console", K_NOTE_WHEN_OFF, V_BOOL, STREAM},
    {"Statistic_File", K_NOTE, V_STRING, STREAM},
    {"Subset_End_Frame", K_SUBSET_END, V_FLOAT, NULL},
    {"Subset_Start_Frame", K_SUBSET_START, V_FLOAT, NULL},
    {"Test_Abort", K_NOTE_WHEN_ON, V_BOOL, "Ctrl-C (or SIGTERM) stops a vbnl render and writes the partial image"},
    {"Test_Abort_Count", K_NOTE, V_INT, "Ctrl-C (or SIGTERM) stops a vbnl render and writes the partial image"},
    {"User_Abort_Command", K_NOTE, V_STRING, SHELL},
    {"User_Abort_Return", K_NOTE, V_STRING, SHELL},
    {"Verbose", K_VERBOSE, V_BOOL, NULL},
    {"Version", K_VERSION, V_FLOAT, NULL},
    {"Video_Mode", K_NOTE, V_STRING, PREVIEW},
    {"Vista_Buffer", K_NOTE_WHEN_ON, V_BOOL, BOUNDS},
    {"Warning_Console", K_NOTE_WHEN_OFF, V_BOOL, STREAM},
    {"Warning_File", K_NOTE, V_STRING, STREAM},
    {"Warning_Level", K_NOTE, V_INT, STREAM},
    {"Width", K_WIDTH, V_INT, NULL},
    {"Work_Threads", K_THREADS, V_INT, NULL},
};

/* Switches: +X turns X on, -X off; a parameter sets the value. param: 0 none, 1 required, 2
 * optional. Within one first letter the longer switch comes first, as POV-Ray matches them. */
typedef struct switch_row {
    const char *sw;
    const char *key; /* the .ini key it sets (its note, its value type) */
    int param;
    pov_kind bool_kind; /* what the sign does (K_NOTE: nothing beyond the key) */
} switch_row;

static const switch_row switches[] = {
    {"AG", "Antialias_Gamma", 1, K_NOTE},        {"AM", "Sampling_Method", 1, K_NOTE},
    {"A", "Antialias_Threshold", 2, K_NOTE},     {"BM", "Bounding_Method", 1, K_NOTE},
    {"BS", "Render_Block_Size", 1, K_NOTE},      {"B", "Bounding", 0, K_NOTE},
    {"C", "Continue_Trace", 0, K_NOTE},          {"D", "Display", 2, K_NOTE},
    {"EC", "End_Column", 1, K_NOTE},             {"EF", "Subset_End_Frame", 1, K_NOTE},
    {"EP", "Preview_End_Size", 1, K_NOTE},       {"ER", "End_Row", 1, K_NOTE},
    {"F", "Output_File_Type", 2, K_OUTPUT_TO_FILE},
    {"GA", "All_File", 2, K_ALL_CONSOLE},        {"GD", "Debug_File", 2, K_NOTE},
    {"GF", "Fatal_File", 2, K_NOTE},             {"GI", "Create_Ini", 1, K_NOTE},
    {"GP", "Append_File", 0, K_NOTE},            {"GR", "Render_File", 2, K_RENDER_CONSOLE},
    {"GS", "Statistic_File", 2, K_NOTE},         {"GW", "Warning_File", 2, K_NOTE},
    {"HI", "Include_Header", 1, K_NOTE},         {"HR", "High_Reproducibility", 0, K_NOTE},
    {"H", "Height", 1, K_NOTE},                  {"I", "Input_File_Name", 1, K_NOTE},
    {"J", "Jitter_Amount", 2, K_NOTE},           {"KC", "Cyclic_Animation", 0, K_NOTE},
    {"KI", "Initial_Clock", 1, K_NOTE},          {"KFF", "Final_Frame", 1, K_NOTE},
    {"KFI", "Initial_Frame", 1, K_NOTE},         {"KF", "Final_Clock", 1, K_NOTE},
    {"KLA", "Clockless_Animation", 0, K_NOTE},   {"K", "Clock", 1, K_NOTE},
    {"L", "Library_Path", 1, K_NOTE},            {"MB", "Bounding_Threshold", 2, K_NOTE},
    {"MI", "Max_Image_Buffer_Memory", 1, K_NOTE}, {"MV", "Version", 1, K_NOTE},
    {"O", "Output_File_Name", 1, K_NOTE},        {"P", "Pause_When_Done", 0, K_NOTE},
    {"Q", "Quality", 1, K_NOTE},                 {"RFI", "Radiosity_From_File", 0, K_NOTE},
    {"RFO", "Radiosity_To_File", 0, K_NOTE},     {"RF", "Radiosity_File_Name", 1, K_NOTE},
    {"RS", "Render_Block_Step", 1, K_NOTE},      {"RP", "Render_Pattern", 1, K_NOTE},
    {"RTR", "Real_Time_Raytracing", 0, K_NOTE},  {"RVP", "Radiosity_Vain_Pretrace", 0, K_NOTE},
    {"R", "Antialias_Depth", 1, K_NOTE},         {"SC", "Start_Column", 1, K_NOTE},
    {"SF", "Subset_Start_Frame", 1, K_NOTE},     {"SP", "Preview_Start_Size", 1, K_NOTE},
    {"SR", "Start_Row", 1, K_NOTE},              {"STP", "Frame_Step", 1, K_NOTE},
    {"SU", "Split_Unions", 0, K_NOTE},           {"TH", "Dither_Method", 2, K_DITHER},
    {"UA", "Output_Alpha", 0, K_NOTE},           {"UD", "Draw_Vistas", 0, K_NOTE},
    {"UF", "Field_Render", 0, K_NOTE},           {"UL", "Light_Buffer", 0, K_NOTE},
    {"UO", "Odd_Field", 0, K_NOTE},              {"UR", "Remove_Bounds", 0, K_NOTE},
    {"UV", "Vista_Buffer", 0, K_NOTE},           {"V", "Verbose", 0, K_NOTE},
    {"WL", "Warning_Level", 1, K_NOTE},          {"WT", "Work_Threads", 1, K_NOTE},
    {"W", "Width", 1, K_NOTE},                   {"X", "Test_Abort_Count", 2, K_NOTE},
};

/* The switches whose parameter-less form is a boolean of another key (+A: Antialias, +D:
 * Display, +J: Jitter, +MB: Bounding, +X: Test_Abort, +F: Output_To_File, +TH: Dither). */
static const char *const sign_keys[][2] = {
    {"A", "Antialias"}, {"D", "Display"},  {"J", "Jitter"},         {"MB", "Bounding"},
    {"X", "Test_Abort"}, {"F", "Output_To_File"}, {"TH", "Dither"}, {"GA", "All_Console"},
    {"GR", "Render_Console"}, {"GD", "Debug_Console"}, {"GF", "Fatal_Console"}, {"GS", "Statistic_Console"},
    {"GW", "Warning_Console"},
};

void pov_settings_init(pov_settings *s)
{
    memset(s, 0, sizeof(*s));
    s->width = 160;
    s->height = 120;
    s->file_type = 'N';
    s->bits = 8;
    s->output_to_file = 1;
    s->frame_step = 1;
    s->final_clock = 1.0;
    s->render_console = 1;
}

static void strings_free(pov_strings *l)
{
    for (size_t i = 0; i < l->n; ++i)
        free(l->v[i]);
    free(l->v);
    l->v = NULL;
    l->n = 0;
}

void pov_settings_free(pov_settings *s)
{
    free(s->input);
    free(s->output);
    free(s->all_file);
    strings_free(&s->library);
    strings_free(&s->declares);
    strings_free(&s->ini_files);
    strings_free(&s->notes);
    memset(s, 0, sizeof(*s));
}

int pov_strings_add(pov_strings *l, const char *text)
{
    char **v = realloc(l->v, (l->n + 1) * sizeof(*v));
    if (!v)
        return -1;
    l->v = v;
    if (!(v[l->n] = strdup(text)))
        return -1;
    l->n++;
    return 0;
}

static const key_row *find_key(const char *name, size_t len)
{
    for (size_t i = 0; i < sizeof(keys) / sizeof(keys[0]); ++i)
        if (strlen(keys[i].key) == len && !strncasecmp(keys[i].key, name, len))
            return &keys[i];
    return NULL;
}

static int set_string(char **dst, const char *v)
{
    char *c = strdup(v);
    if (!c)
        return -1;
    free(*dst);
    *dst = c;
    return 0;
}

/* One note per key. */
static int note(pov_settings *s, const char *key, const char *why)
{
    size_t kl = strlen(key);
    for (size_t i = 0; i < s->notes.n; ++i)
        if (!strncmp(s->notes.v[i], key, kl) && s->notes.v[i][kl] == ':')
            return 0;
    char text[512];
    snprintf(text, sizeof(text), "%s: does not apply: %s", key, why);
    return pov_strings_add(&s->notes, text);
}

/* POV-Ray's booleans: on, true, yes, 1 and off, false, no, 0 (any case). -1 for another word. */
static int parse_bool(const char *v)
{
    static const char *const on[] = {"on", "true", "yes", "1"}, *const off[] = {"off", "false", "no", "0"};
    for (int i = 0; i < 4; ++i) {
        if (!strcasecmp(v, on[i]))
            return 1;
        if (!strcasecmp(v, off[i]))
            return 0;
    }
    return -1;
}

static int parse_long(const char *v, long *out)
{
    char *end;
    errno = 0;
    long x = strtol(v, &end, 10);
    if (errno || end == v || *end)
        return -1;
    *out = x;
    return 0;
}

static int parse_double(const char *v, double *out)
{
    char *end;
    double x = strtod(v, &end);
    if (end == v || *end || !isfinite(x))
        return -1;
    *out = x;
    return 0;
}

static int read_ini(pov_settings *s, const char *spec, const char *where);
static int bare_string(pov_settings *s, const char *text, const char *where);

/* Output_File_Type / +F: N (PNG, 8 bits unless a number follows) or E (OpenEXR). */
static int file_type(pov_settings *s, const char *v, const char *where)
{
    char t = (char)toupper((unsigned char)v[0]);
    if (t == 'N' || t == 'E') {
        s->file_type = t;
        if (!v[1])
            return 0;
        long bits;
        if (t == 'N' && parse_long(v + 1, &bits) == 0 && (bits == 8 || bits == 16)) {
            s->bits = (int)bits;
            return 0;
        }
        fprintf(stderr, "vbnl: %s: output file type '%s': vbnl writes N (PNG), N8, N16 and E (OpenEXR)\n", where, v);
        return -1;
    }
    fprintf(stderr,
            "vbnl: %s: output file type '%s' is not one vbnl writes: N (PNG; N8, N16) or E (OpenEXR)\n",
            where, v);
    return -1;
}

/* Applies key `k` with value `v` (a switch without parameter passes NULL and its sign in `on`).
 * Returns 0, or -1 after the error. */
static int apply(pov_settings *s, const key_row *k, const char *v, int on, const char *where)
{
    int b = on;
    long i = 0;
    double f = 0;
    if (v) {
        int bad = 0;
        switch (k->value) {
        case V_BOOL: bad = (b = parse_bool(v)) < 0; break;
        case V_INT: bad = parse_long(v, &i) != 0; break;
        case V_FLOAT: bad = parse_double(v, &f) != 0; break;
        default: break;
        }
        if (bad) {
            fprintf(stderr, "vbnl: %s: %s takes %s, got '%s'\n", where, k->key,
                    k->value == V_BOOL ? "on or off (true, yes, 1; false, no, 0)"
                    : k->value == V_INT ? "a whole number"
                                        : "a number",
                    v);
            return -1;
        }
    } else if (k->value != V_BOOL && k->value != V_NONE) {
        fprintf(stderr, "vbnl: %s: %s takes a value\n", where, k->key);
        return -1;
    }
    switch (k->kind) {
    case K_INPUT: return set_string(&s->input, v);
    case K_OUTPUT: return set_string(&s->output, v);
    case K_WIDTH:
    case K_HEIGHT:
        if (i < 1 || i > 65536) {
            fprintf(stderr, "vbnl: %s: %s takes 1..65536, got '%s'\n", where, k->key, v);
            return -1;
        }
        *(k->kind == K_WIDTH ? &s->width : &s->height) = i;
        return 0;
    case K_START_COL:
    case K_START_ROW:
    case K_END_COL:
    case K_END_ROW: {
        int r = k->kind - K_START_COL;
        /* order: Start_Column, Start_Row, End_Column, End_Row */
        if (f < 0) {
            fprintf(stderr, "vbnl: %s: %s must not be negative, got '%s'\n", where, k->key, v);
            return -1;
        }
        s->region[r] = f;
        s->have_region[r] = 1;
        return 0;
    }
    case K_FILE_TYPE: return file_type(s, v, where);
    case K_BITS:
        if (i != 8 && i != 16) {
            if (i < 1 || i > 16) {
                fprintf(stderr, "vbnl: %s: %s takes 1..16, got '%s'\n", where, k->key, v);
                return -1;
            }
            note(s, k->key, "vbnl writes 8 or 16 bits per colour; the nearer of the two is written");
        }
        s->bits = i > 8 ? 16 : 8;
        return 0;
    case K_ALPHA: s->alpha = b; return 0;
    case K_OUTPUT_TO_FILE: s->output_to_file = b; return 0;
    case K_LIBRARY: return pov_strings_add(&s->library, v);
    case K_DECLARE: {
        /* NAME=VALUE with VALUE a number, or a string in double quotes ("'" too, as in POV-Ray) */
        const char *eq = strchr(v, '=');
        if (!eq || eq == v || !eq[1]) {
            fprintf(stderr, "vbnl: %s: Declare takes NAME=VALUE, got '%s'\n", where, v);
            return -1;
        }
        char text[1024];
        const char *val = eq + 1;
        size_t vl = strlen(val);
        if (vl >= 2 && val[0] == '\'' && val[vl - 1] == '\'')
            snprintf(text, sizeof(text), "%.*s=\"%.*s\"", (int)(eq - v), v, (int)(vl - 2), val + 1);
        else
            snprintf(text, sizeof(text), "%s", v);
        return pov_strings_add(&s->declares, text);
    }
    case K_INCLUDE_INI: return read_ini(s, v, where);
    case K_INITIAL_FRAME:
    case K_FINAL_FRAME:
        if (i < 0 || i > 999999999) {
            fprintf(stderr, "vbnl: %s: %s takes 0..999999999, got '%s'\n", where, k->key, v);
            return -1;
        }
        if (k->kind == K_INITIAL_FRAME) {
            s->initial_frame = i;
            s->have_initial_frame = 1;
        } else {
            s->final_frame = i;
            s->have_final_frame = 1;
        }
        return 0;
    case K_INITIAL_CLOCK: s->initial_clock = f; return 0;
    case K_FINAL_CLOCK: s->final_clock = f; return 0;
    case K_CLOCK:
        s->clock = f;
        s->have_clock = 1;
        return 0;
    case K_SUBSET_START:
    case K_SUBSET_END:
        if (f < 0) {
            fprintf(stderr, "vbnl: %s: %s must not be negative, got '%s'\n", where, k->key, v);
            return -1;
        }
        *(k->kind == K_SUBSET_START ? &s->subset_start : &s->subset_end) = f;
        *(k->kind == K_SUBSET_START ? &s->have_subset_start : &s->have_subset_end) = 1;
        return 0;
    case K_CYCLIC: s->cyclic = b; return 0;
    case K_FRAME_STEP: s->frame_step = i < 1 ? 1 : i; return 0;
    case K_ALL_FILE: {
        /* on: alltext.out; off: none; a name: that file, beside the image (POV-Ray allows only a
         * plain file name there) */
        int tf = parse_bool(v);
        if (tf == 0) {
            free(s->all_file);
            s->all_file = NULL;
            return 0;
        }
        if (tf == 1)
            return set_string(&s->all_file, "alltext.out");
        if (strchr(v, '/')) {
            fprintf(stderr, "vbnl: %s: All_File '%s': a file name without folder (it is written beside the image)\n",
                    where, v);
            return -1;
        }
        return set_string(&s->all_file, v);
    }
    case K_APPEND_FILE: s->append_file = b; return 0;
    case K_ALL_CONSOLE:
    case K_RENDER_CONSOLE: s->render_console = b; return 0;
    case K_VERBOSE: s->verbose = b; return 0;
    case K_THREADS:
        if (i < 1 || i > 1024) {
            fprintf(stderr, "vbnl: %s: %s takes 1..1024, got '%s'\n", where, k->key, v);
            return -1;
        }
        s->threads = i;
        return 0;
    case K_VERSION:
        if (fabs(f - 3.7) > 1e-9)
            note(s, k->key, "vbnl reads the scene in the language version its #version directives give (3.7 before one)");
        return 0;
    case K_DITHER:
        if (!b)
            note(s, k->key, "vbnl always dithers its PNG with triangular noise");
        return 0;
    case K_NOTE_WHEN_ON: return b ? note(s, k->key, k->why) : 0;
    case K_NOTE_WHEN_OFF: return !b ? note(s, k->key, k->why) : 0;
    case K_NOTE: return note(s, k->key, k->why);
    }
    return 0;
}

/* KEY=VALUE[, VALUE ...] (the values already split). */
static int key_value(pov_settings *s, const char *key, size_t klen, const char *value, const char *where)
{
    const key_row *k = find_key(key, klen);
    if (!k) {
        fprintf(stderr, "vbnl: %s: unknown key '%.*s' (POV-Ray 3.7 has no such option)\n", where, (int)klen, key);
        return -1;
    }
    if (!value[0]) {
        /* POV-Ray reads an empty value as no value */
        fprintf(stderr, "vbnl: %s: %s has no value\n", where, k->key);
        return -1;
    }
    return apply(s, k, value, 1, where);
}

/* A switch without its sign: "W640", "UA", "Iscene.pov". */
static int one_switch(pov_settings *s, char sign, const char *text, const char *where)
{
    for (size_t i = 0; i < sizeof(switches) / sizeof(switches[0]); ++i) {
        const switch_row *w = &switches[i];
        size_t n = strlen(w->sw);
        if (strncasecmp(text, w->sw, n))
            continue;
        const char *param = text + n;
        if ((*param && w->param == 0) || (!*param && w->param == 1))
            continue;
        int on = sign != '-';
        if (!*param) {
            /* the sign alone: the switch's boolean */
            for (size_t j = 0; j < sizeof(sign_keys) / sizeof(sign_keys[0]); ++j)
                if (!strcasecmp(sign_keys[j][0], w->sw))
                    return apply(s, find_key(sign_keys[j][1], strlen(sign_keys[j][1])), NULL, on, where);
            return apply(s, find_key(w->key, strlen(w->key)), NULL, on, where);
        }
        /* a quoted parameter loses its quotes */
        char buf[4096];
        size_t pl = strlen(param);
        if (pl >= 2 && (param[0] == '"' || param[0] == '\'') && param[pl - 1] == param[0])
            snprintf(buf, sizeof(buf), "%.*s", (int)(pl - 2), param + 1);
        else
            snprintf(buf, sizeof(buf), "%s", param);
        if (!strcasecmp(w->sw, "D")) /* +D with a video mode: the display */
            return apply(s, find_key("Display", 7), NULL, on, where);
        const key_row *k = find_key(w->key, strlen(w->key));
        int r = apply(s, k, buf, on, where);
        /* +GAfile and +GRfile set the console too; +A0.3 also turns antialiasing on */
        for (size_t j = 0; r == 0 && j < sizeof(sign_keys) / sizeof(sign_keys[0]); ++j)
            if (!strcasecmp(sign_keys[j][0], w->sw) && strcasecmp(w->sw, "F") && strcasecmp(w->sw, "TH") &&
                strcasecmp(w->sw, "D"))
                r = apply(s, find_key(sign_keys[j][1], strlen(sign_keys[j][1])), NULL, on, where);
        if (r == 0 && !strcasecmp(w->sw, "F"))
            s->output_to_file = on;
        return r;
    }
    fprintf(stderr, "vbnl: %s: unknown switch '%c%s' (POV-Ray 3.7 has no such switch)\n", where, sign, text);
    return -1;
}

static int has_suffix(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    return n >= k && !strcasecmp(s + n - k, suffix);
}

/* A bare string: a .pov file is the scene, a name ending in '/' a library folder, anything else
 * an .ini file (POV-Ray reads it where it stands). */
static int bare_string(pov_settings *s, const char *text, const char *where)
{
    if (!text[0])
        return 0;
    const char *dot = strrchr(text, '.');
    if (dot && !strcasecmp(dot, ".pov"))
        return set_string(&s->input, text);
    if (text[strlen(text) - 1] == '/')
        return pov_strings_add(&s->library, text);
    return read_ini(s, text, where);
}

int pov_settings_is_pov(const char *arg)
{
    if (arg[0] == '+' || (arg[0] == '-' && isalpha((unsigned char)arg[1]) && strcmp(arg, "-h")))
        return 1;
    if (has_suffix(arg, ".ini") || has_suffix(arg, ".pov") || (strchr(arg, '[') && strstr(arg, ".ini[")))
        return 1;
    const char *eq = strchr(arg, '=');
    return eq && find_key(arg, (size_t)(eq - arg)) != NULL;
}

int pov_settings_argument(pov_settings *s, const char *arg)
{
    const char *where = "command line";
    if (arg[0] == '+' || arg[0] == '-')
        return one_switch(s, arg[0], arg + 1, where);
    const char *eq = strchr(arg, '=');
    if (eq && eq > arg && (isalnum((unsigned char)arg[0]) || arg[0] == '_')) {
        size_t kl = (size_t)(eq - arg);
        while (kl && isspace((unsigned char)arg[kl - 1]))
            --kl;
        const char *v = eq + 1;
        while (isspace((unsigned char)*v))
            ++v;
        char buf[4096];
        size_t vl = strlen(v);
        if (vl >= 2 && (v[0] == '"' || v[0] == '\'') && v[vl - 1] == v[0])
            snprintf(buf, sizeof(buf), "%.*s", (int)(vl - 2), v + 1);
        else
            snprintf(buf, sizeof(buf), "%s", v);
        if (find_key(arg, kl))
            return key_value(s, arg, kl, buf, where);
        if (!has_suffix(arg, ".ini") && !has_suffix(arg, ".pov")) {
            fprintf(stderr, "vbnl: %s: unknown key '%.*s' (POV-Ray 3.7 has no such option)\n", where, (int)kl, arg);
            return -1;
        }
    }
    return bare_string(s, arg, where);
}

/* ---- .ini files --------------------------------------------------------------------------------- */

/* The next item of an .ini line at *p: a quoted string (without its quotes) or a run up to
 * white space, ',', ';' or '#'. Returns its length in out (0 at the end of the line). */
static size_t ini_token(const char **p, char *out, size_t n)
{
    const char *c = *p;
    while (*c == ' ' || *c == '\t')
        ++c;
    size_t len = 0;
    if (*c == '"' || *c == '\'') {
        char q = *c++;
        while (*c && *c != q && len + 1 < n)
            out[len++] = *c++;
        if (*c == q)
            ++c;
    } else {
        while (*c && !isspace((unsigned char)*c) && *c != ',' && *c != ';' && *c != '#' && len + 1 < n)
            out[len++] = *c++;
    }
    out[len] = '\0';
    *p = c;
    return len;
}

/* One item of a line of switches: a switch, KEY=VALUE (POV-Ray reads "+kff20 declare=fp=0"), or a
 * bare file name. */
static int line_token(pov_settings *s, const char *tok, const char *where)
{
    if (tok[0] == '+' || tok[0] == '-')
        return one_switch(s, tok[0], tok + 1, where);
    const char *eq = strchr(tok, '=');
    if (eq && eq > tok) {
        if (!find_key(tok, (size_t)(eq - tok))) {
            fprintf(stderr, "vbnl: %s: unknown key '%.*s' (POV-Ray 3.7 has no such option)\n", where,
                    (int)(eq - tok), tok);
            return -1;
        }
        return key_value(s, tok, (size_t)(eq - tok), eq + 1, where);
    }
    return bare_string(s, tok, where);
}

/* The value of KEY= at *p: quoted, or unquoted up to a comment or the end of the line when
 * the rest does not look like another option (POV-Ray's "smart mode" for unquoted paths with
 * spaces), else up to white space; then more values after commas. */
static int ini_values(pov_settings *s, const char *key, size_t klen, const char *p, const char *where)
{
    for (;;) {
        char value[4096];
        while (*p == ' ' || *p == '\t')
            ++p;
        if (*p == '"' || *p == '\'') {
            ini_token(&p, value, sizeof(value));
        } else {
            size_t len = strcspn(p, ";#,\r\n");
            while (len && isspace((unsigned char)p[len - 1]))
                --len;
            /* cut at the first white space when what follows starts another option */
            size_t word = strcspn(p, " \t;#,\r\n");
            const char *rest = p + word;
            while (*rest == ' ' || *rest == '\t')
                ++rest;
            int another = rest[0] == '+' || rest[0] == '-' || (strchr(rest, '=') && strcspn(rest, "=") < strcspn(rest, " \t"));
            if (word < len && another)
                len = word;
            snprintf(value, sizeof(value), "%.*s", (int)len, p);
            p += len;
        }
        if (key_value(s, key, klen, value, where) != 0)
            return -1;
        while (*p == ' ' || *p == '\t')
            ++p;
        if (*p != ',')
            break;
        ++p;
    }
    /* switches may follow on the line */
    char tok[4096];
    const char *q = p;
    while (ini_token(&q, tok, sizeof(tok)))
        if (line_token(s, tok, where) != 0)
            return -1;
    return 0;
}

/* FILE.ini or FILE.ini[Section]. Options before any section apply; a named section applies only
 * when it is the one asked for. */
static int read_ini(pov_settings *s, const char *spec, const char *where)
{
    char path[4096], section[256] = "";
    snprintf(path, sizeof(path), "%s", spec);
    char *br = strrchr(path, '[');
    if (br && path[strlen(path) - 1] == ']') {
        snprintf(section, sizeof(section), "%.*s", (int)(strlen(br) - 2), br + 1);
        *br = '\0';
    }
    if (s->depth >= 16) {
        fprintf(stderr, "vbnl: %s: .ini files nested more than 16 deep at '%s'\n", where, path);
        return -1;
    }
    const char *why;
    FILE *f = vbi_read_fopen(path, NULL, &why); /* a FIFO is refused, not waited on (read_file.h) */
    if (!f) {
        fprintf(stderr, "vbnl: %s: cannot open INI file '%s': %s\n", where, path, why);
        return -1;
    }
    if (pov_strings_add(&s->ini_files, path) != 0) {
        fclose(f);
        return -1;
    }
    s->depth++;
    char line[8192], here[4200];
    int lineno = 0, active = 1, rc = 0;
    while (rc == 0 && fgets(line, sizeof(line), f)) {
        ++lineno;
        snprintf(here, sizeof(here), "%s:%d", path, lineno);
        const char *p = line;
        while (isspace((unsigned char)*p))
            ++p;
        if (!*p || *p == ';' || *p == '#')
            continue;
        if (*p == '[') {
            const char *end = strchr(p, ']');
            if (!end) {
                fprintf(stderr, "vbnl: %s: a section name without ']'\n", here);
                rc = -1;
                break;
            }
            active = section[0] && (size_t)(end - p - 1) == strlen(section) && !strncasecmp(p + 1, section, strlen(section));
            continue;
        }
        if (!active)
            continue;
        if (*p == '+' || *p == '-') {
            char tok[4096];
            while (rc == 0 && ini_token(&p, tok, sizeof(tok)))
                rc = line_token(s, tok, here);
            continue;
        }
        if (isalnum((unsigned char)*p) || *p == '_') {
            size_t kl = strcspn(p, " \t=;#\r\n");
            const char *after = p + kl;
            while (*after == ' ' || *after == '\t')
                ++after;
            if (*after == '=') {
                rc = ini_values(s, p, kl, after + 1, here);
                continue;
            }
            if (find_key(p, kl)) {
                fprintf(stderr, "vbnl: %s: %.*s without '=' and a value\n", here, (int)kl, p);
                rc = -1;
                continue;
            }
        }
        /* a bare string: a .pov or .ini file, a library folder */
        char tok[4096];
        if (ini_token(&p, tok, sizeof(tok))) {
            if (strchr(tok, '=')) {
                fprintf(stderr, "vbnl: %s: unknown key '%.*s' (POV-Ray 3.7 has no such option)\n", here,
                        (int)strcspn(tok, "="), tok);
                rc = -1;
            } else {
                rc = bare_string(s, tok, here);
            }
        }
    }
    s->depth--;
    fclose(f);
    return rc;
}
