/* The sizing rule of sizing.h. */
#include "sizing.h"

#include <math.h>
#include <stdio.h>

double vbi_sizing_lights_wanted(double budget, double pixels)
{
    double want = VBI_SIZING_LIGHTS_PER_PIXEL * pixels * fmax(1.0, budget / VBI_SIZING_LIGHTS_KNEE);
    return fmin(VBI_SIZING_LIGHTS_MAX, fmax(VBI_SIZING_LIGHTS_MIN, floor(want)));
}

void vbi_size_to_budget(const vbi_sizing_in *in, vbi_sizing_out *out)
{
    const double cl = in->seconds_per_light > 0.0 ? in->seconds_per_light : 1e-9;
    const double cp = in->seconds_per_path > 0.0 ? in->seconds_per_path : 1e-9;
    const double left =
        fmax(0.0, VBI_SIZING_AIM * in->prepare_limit - in->elapsed - in->fixed_seconds * VBI_SIZING_MARGIN);
    if (in->lights_set) {
        out->lights = in->lights;
        snprintf(out->lights_why, sizeof(out->lights_why), "set explicitly, kept (%.3g s estimated)",
                 out->lights * cl);
    } else {
        double want = vbi_sizing_lights_wanted(in->budget, in->pixels);
        double fit = floor(0.5 * left / (cl * VBI_SIZING_MARGIN));
        out->lights = fmax(VBI_SIZING_LIGHTS_FLOOR, fmin(want, fit));
        snprintf(out->lights_why, sizeof(out->lights_why),
                 "sized: %.0f for %.0f pixels and %g s%s; %.3g us per light measured", want, in->pixels,
                 in->budget, out->lights < want ? ", lowered to fit half the preparation bound" : "", cl * 1e6);
    }
    const double t_lights = out->lights * cl;
    if (in->paths_set) {
        out->paths = in->paths;
        snprintf(out->paths_why, sizeof(out->paths_why), "set explicitly, kept (%.3g s estimated)", out->paths * cp);
    } else {
        double t = fmin(VBI_SIZING_PHOTON_SHARE * in->budget, left - t_lights * VBI_SIZING_MARGIN);
        double p = floor(t / (cp * VBI_SIZING_MARGIN));
        out->paths = fmax(VBI_SIZING_PATHS_FLOOR, fmin(VBI_SIZING_PATHS_MAX, p));
        snprintf(out->paths_why, sizeof(out->paths_why),
                 "sized: the paths of %.3g s (%g%% of the budget%s) at %.3g us per path measured", t,
                 100.0 * VBI_SIZING_PHOTON_SHARE,
                 t < VBI_SIZING_PHOTON_SHARE * in->budget ? ", less: what the preparation bound leaves" : "",
                 cp * 1e6);
    }
    out->estimate = in->elapsed + in->fixed_seconds + t_lights + out->paths * cp;
    out->fits = out->estimate <= in->prepare_limit || (!in->lights_set && !in->paths_set);
}
