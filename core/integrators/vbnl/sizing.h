/* How `vbnl` sizes its preparation to a time budget (docs/time-budget.md has the measurements).
 *
 * Under a budget B seconds for an image of `pixels` pixels, preparation (calibration included)
 * may take at most VBNL_BUDGET_PREPARE_SHARE x B. A short calibration on the scene (a complete
 * preparation of VBNL_SIZING_CAL_LIGHTS lights, thrown away, whose photon splitting runs twice:
 * VBNL_SIZING_CAL_PATHS_FIRST paths, then VBNL_SIZING_CAL_PATHS more) measures the seconds per
 * light of placement, elimination, the index, support and profiles, the seconds per photon path
 * (the difference of the two runs), and the fixed seconds the preparation pays whatever its
 * counts (conversion kernels per material, maps, splitting's set-up). Then, with the fixed
 * seconds taken from what the bound leaves:
 *
 *   lights   N = VBNL_SIZING_LIGHTS_PER_PIXEL x pixels x max(1, B / VBNL_SIZING_LIGHTS_KNEE),
 *            clamped to [VBNL_SIZING_LIGHTS_MIN, VBNL_SIZING_LIGHTS_MAX], and lowered (not below
 *            VBNL_SIZING_LIGHTS_FLOOR) until its estimated time is at most half of what the bound
 *            leaves after the calibration and the fixed seconds;
 *   photons  P = the paths that fit VBNL_SIZING_PHOTON_SHARE x B, or what the bound leaves after
 *            the lights when that is less; at most VBNL_SIZING_PATHS_MAX, at least
 *            VBNL_SIZING_PATHS_FLOOR.
 *
 * "The bound" above is VBNL_SIZING_AIM of it: the rest is kept for what the estimates miss
 * (allocations that grow with the counts, a machine shared with other work). Estimates carry a
 * margin of VBNL_SIZING_MARGIN (calibration noise; the photon rate falls a little as the set
 * grows). A count the user set is kept; when the estimate (without margin)
 * with the user's counts exceeds the bound, the plan does not fit and the integrator refuses
 * before preparing. */
#ifndef VBNL_SIZING_H
#define VBNL_SIZING_H

#include <stdint.h>

#define VBNL_SIZING_CAL_LIGHTS 1024u
#define VBNL_SIZING_CAL_PATHS_FIRST 4096u
#define VBNL_SIZING_CAL_PATHS 16384u
#define VBNL_SIZING_LIGHTS_PER_PIXEL (20000.0 / (512.0 * 512.0))
#define VBNL_SIZING_LIGHTS_KNEE 50.0
#define VBNL_SIZING_LIGHTS_MIN 1000.0
#define VBNL_SIZING_LIGHTS_MAX 130000.0
#define VBNL_SIZING_LIGHTS_FLOOR 64.0
#define VBNL_SIZING_PHOTON_SHARE 0.08
#define VBNL_SIZING_PATHS_MAX 2e7
#define VBNL_SIZING_PATHS_FLOOR 1000.0
#define VBNL_SIZING_MARGIN 1.25
#define VBNL_SIZING_AIM 0.8

typedef struct vbnl_sizing_in {
    double budget;             /* seconds, > 0 */
    double prepare_limit;      /* seconds preparation may take */
    double pixels;             /* pixels rendered */
    double elapsed;            /* seconds of the budget spent (the calibration) */
    double fixed_seconds;      /* measured: the preparation's cost whatever its counts */
    double seconds_per_light;  /* measured: placement, elimination, support, profiles */
    double seconds_per_path;   /* measured: photon splitting */
    int lights_set, paths_set; /* the user set virtual_lights / photon_paths */
    double lights, paths;      /* their values when set */
} vbnl_sizing_in;

typedef struct vbnl_sizing_out {
    double lights, paths;
    double estimate;           /* seconds of preparation in all, calibration and fixed costs included,
                                  no margin */
    int fits;                  /* estimate <= prepare_limit (always 1 when nothing was set) */
    char lights_why[200], paths_why[200];
} vbnl_sizing_out;

void vbnl_size_to_budget(const vbnl_sizing_in *in, vbnl_sizing_out *out);
/* The light count the rule asks for before the time cap (an upper bound of the sized count). */
double vbnl_sizing_lights_wanted(double budget, double pixels);

#endif
