/* How `vbnl` sizes its preparation to a time budget (docs/time-budget.md has the measurements).
 *
 * Under a budget B seconds for an image of `pixels` pixels, preparation (calibration included)
 * may take at most VBNL_BUDGET_PREPARE_SHARE x B. A short calibration on the scene (a complete
 * preparation of VBI_SIZING_CAL_LIGHTS lights, thrown away, whose photon splitting runs twice:
 * VBI_SIZING_CAL_PATHS_FIRST paths, then VBI_SIZING_CAL_PATHS more) measures the seconds per
 * light of placement, elimination, the index, support and profiles, the seconds per photon path
 * (the difference of the two runs), and the fixed seconds the preparation pays whatever its
 * counts (conversion kernels per material, maps, splitting's set-up). Then, with the fixed
 * seconds taken from what the bound leaves:
 *
 *   lights   N = VBI_SIZING_LIGHTS_PER_PIXEL x pixels x max(1, B / VBI_SIZING_LIGHTS_KNEE),
 *            clamped to [VBI_SIZING_LIGHTS_MIN, VBI_SIZING_LIGHTS_MAX], and lowered (not below
 *            VBI_SIZING_LIGHTS_FLOOR) until its estimated time is at most half of what the bound
 *            leaves after the calibration and the fixed seconds;
 *   photons  P = the paths that fit VBI_SIZING_PHOTON_SHARE x B, or what the bound leaves after
 *            the lights when that is less; at most VBI_SIZING_PATHS_MAX, at least
 *            VBI_SIZING_PATHS_FLOOR.
 *
 * "The bound" above is VBI_SIZING_AIM of it: the rest is kept for what the estimates miss
 * (allocations that grow with the counts, a machine shared with other work). Estimates carry a
 * margin of VBI_SIZING_MARGIN (calibration noise; the photon rate falls a little as the set
 * grows). A count the user set is kept; when the estimate (without margin)
 * with the user's counts exceeds the bound, the plan does not fit and the integrator refuses
 * before preparing. */
#ifndef VBI_SIZING_H
#define VBI_SIZING_H

#include <stdint.h>

#define VBI_SIZING_CAL_LIGHTS 1024u
#define VBI_SIZING_CAL_PATHS_FIRST 4096u
#define VBI_SIZING_CAL_PATHS 16384u
#define VBI_SIZING_LIGHTS_PER_PIXEL (20000.0 / (512.0 * 512.0))
#define VBI_SIZING_LIGHTS_KNEE 50.0
#define VBI_SIZING_LIGHTS_MIN 1000.0
#define VBI_SIZING_LIGHTS_MAX 130000.0
#define VBI_SIZING_LIGHTS_FLOOR 64.0
#define VBI_SIZING_PHOTON_SHARE 0.08
#define VBI_SIZING_PATHS_MAX 2e7
#define VBI_SIZING_PATHS_FLOOR 1000.0
#define VBI_SIZING_MARGIN 1.25
#define VBI_SIZING_AIM 0.8

typedef struct vbi_sizing_in {
    double budget;             /* seconds, > 0 */
    double prepare_limit;      /* seconds preparation may take */
    double pixels;             /* pixels rendered */
    double elapsed;            /* seconds of the budget spent (the calibration) */
    double fixed_seconds;      /* measured: the preparation's cost whatever its counts */
    double seconds_per_light;  /* measured: placement, elimination, support, profiles */
    double seconds_per_path;   /* measured: photon splitting */
    int lights_set, paths_set; /* the user set virtual_lights / photon_paths */
    double lights, paths;      /* their values when set */
} vbi_sizing_in;

typedef struct vbi_sizing_out {
    double lights, paths;
    double estimate;           /* seconds of preparation in all, calibration and fixed costs included,
                                  no margin */
    int fits;                  /* estimate <= prepare_limit (always 1 when nothing was set) */
    char lights_why[200], paths_why[200];
} vbi_sizing_out;

void vbi_size_to_budget(const vbi_sizing_in *in, vbi_sizing_out *out);
/* The light count the rule asks for before the time cap (an upper bound of the sized count). */
double vbi_sizing_lights_wanted(double budget, double pixels);

#endif
