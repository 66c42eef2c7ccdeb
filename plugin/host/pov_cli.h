/* POV-Ray 3.7's command line in the `vbnl` executable (pov_cli.c, pov_ini.c):
 *
 *   vbnl [FILE.ini ...] [+/-switches ...] [KEY=VALUE ...] [--vbnl-option ...] [FILE.pov]
 *
 * .ini files, switches and KEY=VALUE options are read from left to right, the later setting
 * winning, as POV-Ray 3.7 reads its command line (an .ini file where it stands, its own .ini
 * files included where they stand); vbnl's own `vbnl render` options may stand among them. Every
 * frame of an animation is one render (host_render_run) with POV-Ray's clock values, written
 * to POV-Ray's numbered file names. The mapping of every key and switch is in
 * docs/povray-command-line.md. */
#ifndef VBI_POV_CLI_H
#define VBI_POV_CLI_H

#include "host.h"

/* 1 when the arguments after `vbnl`'s own (which name no command of `vbnl`) are POV-Ray's command
 * line: one of them is a +/- switch, an .ini or .pov file, or a KEY=VALUE option with one of
 * POV-Ray's keys. */
int pov_cli_applies(int argc, char **argv);

/* Runs POV-Ray's command line argv[0..argc-1]. Returns the process exit status (cli.h): the
 * first frame's that is not 0, else 0. */
int pov_cli_main(const plugin *pl, int argc, char **argv);

#endif
