/* The photon walk out of line (photon_walk.h), for the integrators that visit through a pointer. */
#include "photon_walk.h"

void vbnl_photon_walk(const vbnl_photon_walk_desc *w, vbnl_rng *rng, vbnl_photon_visit_fn visit, void *user,
                      vbnl_photon_walk_stats *st)
{
    vbnl_photon_walk_inline(w, rng, visit, user, st);
}
