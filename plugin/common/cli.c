/* The --camera argument of `vbnl render` (the executable) and `vbnl bench` (the module). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "cli.h"

int cli_parse_camera(const char *text, float position[3], float target[3], float *fov_y)
{
    float v[7];
    char extra;
    if (sscanf(text, "%f,%f,%f,%f,%f,%f,%f%c", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6], &extra) != 7)
        return -1;
    for (int i = 0; i < 7; ++i)
        if (!isfinite(v[i]))
            return -1;
    memcpy(position, v, sizeof(float) * 3);
    memcpy(target, v + 3, sizeof(float) * 3);
    *fov_y = v[6];
    return 0;
}
