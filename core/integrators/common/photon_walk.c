/* The photon walk out of line (photon_walk.h), for the integrators that visit through a pointer. */
#include "photon_walk.h"

void vbi_photon_walk(const vbi_photon_walk_desc *w, vbi_rng *rng, vbi_photon_visit_fn visit, void *user,
                      vbi_photon_walk_stats *st)
{
    vbi_photon_walk_inline(w, rng, visit, user, st);
}
