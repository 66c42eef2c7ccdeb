/* placeholder */
#include "texture.h"
double vbnl_pattern_tiling(int type, dvec3 p) { (void)type; (void)p; return 0.0; }
