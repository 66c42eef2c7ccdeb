/* placeholder */
#include "texture.h"
double vbnl_pattern_pavement(const vbnl_pattern *pt, dvec3 p) { (void)pt; (void)p; return 0.0; }
