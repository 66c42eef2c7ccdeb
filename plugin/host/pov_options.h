/* POV-Ray 3.7's render options as the `vbnl` executable reads them (pov_ini.c): the .ini keys and
 * +/- switches, KEY=VALUE on the command line, .ini files (with [Section] and nested .ini files),
 * and bare file names. Private to pov_cli.c and pov_ini.c.
 *
 * Every key of POV-Ray 3.7's table is known: a key that matters for vbnl's render is honoured,
 * any other is accepted with one note saying that it does not apply; a key or switch POV-Ray does
 * not have is an error naming it and where it stands. */
#ifndef VBI_POV_OPTIONS_H
#define VBI_POV_OPTIONS_H

#include <stddef.h>

/* A growing list of owned strings. */
typedef struct pov_strings {
    char **v;
    size_t n;
} pov_strings;

/* The settings, as the command line and .ini files left them (later ones win). */
typedef struct pov_settings {
    char *input;                   /* Input_File_Name, +I, a bare .pov file */
    char *output;                  /* Output_File_Name, +O (NULL: from the input's name) */
    long width, height;            /* Width, Height (POV-Ray's defaults 160 x 120) */
    double region[4];              /* Start_Column, Start_Row, End_Column, End_Row as given */
    int have_region[4];
    char file_type;                /* Output_File_Type: 'N' PNG (default) or 'E' OpenEXR */
    int bits;                      /* Bits_Per_Color or the number after +FN (8 default, 16) */
    int alpha;                     /* Output_Alpha, +UA */
    int output_to_file;            /* Output_To_File, +F/-F (default on) */
    pov_strings library;           /* Library_Path, +L, a bare folder name ending in '/' */
    pov_strings declares;          /* Declare=NAME=VALUE, as vbnl's declare takes it */
    pov_strings ini_files;         /* every .ini file read (an output never replaces one) */
    long initial_frame, final_frame, frame_step;
    int have_initial_frame, have_final_frame;
    double initial_clock, final_clock, clock;
    int have_clock;                /* Clock, +K: clock_on in a still image */
    double subset_start, subset_end;
    int have_subset_start, have_subset_end;
    int cyclic;                    /* Cyclic_Animation, +KC */
    char *all_file;                /* All_File: "alltext.out" for on, a file name, NULL for off */
    int append_file;               /* Append_File, +GP */
    int render_console;            /* Render_Console / All_Console (default on): progress on stdout */
    int verbose;                   /* Verbose, +V: the settings and vbnl's own stages too */
    long threads;                  /* Work_Threads, +WT (0: unset) */
    pov_strings notes;             /* "KEY: why it does not apply", each once */
    int depth;                     /* .ini files being read inside one another */
} pov_settings;

void pov_settings_init(pov_settings *s);
void pov_settings_free(pov_settings *s);

/* 0, or -1 when out of memory. */
int pov_strings_add(pov_strings *l, const char *text);

/* One argument of the command line that is not one of vbnl's --options: a switch (+W640, -D),
 * KEY=VALUE, an .ini file (FILE.ini or FILE.ini[Section]), a .pov file, or a library folder
 * ending in '/'. Returns 0, or -1 after printing the error on stderr. */
int pov_settings_argument(pov_settings *s, const char *arg);

/* 1 when `arg` would be taken as POV-Ray's: a switch, an .ini or .pov file, or KEY=VALUE with one
 * of POV-Ray's keys. */
int pov_settings_is_pov(const char *arg);

#endif
