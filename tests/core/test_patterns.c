/* POV-Ray 3.7's noise, patterns, warps and waves against POV-Ray itself: each case below is
 * POV-Ray SDL, and its eight expected values are what POV-Ray 3.7.0 prints (#debug, 12 decimals)
 * for `function { pattern { <case> } }` at the eight points of `points`. The same pattern built
 * through vbnl_scene_add_pattern must give those values to 1e-9. Also: turbulence statistics,
 * the noise tables' properties, validation of pattern descriptions. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rng.h"
#include "scene_internal.h"
#include "vbnl/vbnl.h"

static const double points[8][3] = {{0.3, 0.5, 0.7},   {-1.25, 2.5, -0.75}, {3.1, -0.2, 1.9},  {-5.5, -2.25, 7.3},
                                    {0.05, 0.02, -0.01}, {10.3, 4.7, -8.2},  {-0.6, 1.3, 0.45}, {2.2, -3.3, -4.4}};

typedef struct ref_case {
    const char *name;
    double expect[8];
} ref_case;

/* name: the POV-Ray pattern of each case (the table's values come from these):
 *   agate; agate agate_turb 0.5; boxed; bozo noise_generator 1/2/3; brick; brick brick_size
 *   <1,0.5,2> mortar 0.1; bumps; cells; checker; crackle; crackle form <1,0,0>; crackle metric 1;
 *   crackle metric 3 offset 0.2; crackle solid; cubic; cylindrical; dents; gradient <1,2,3>;
 *   granite; granite noise_generator 1; hexagon; julia <0.353,0.288> 30 (exponent 3; exponent 5
 *   interior 1, 0.5 exterior 6, 0.3); leopard; magnet 1 mandel 20; magnet 2 julia <0.2,0.3> 20;
 *   mandel 25 (exponent 4; exponent 6 exterior 3, 0.4); marble; marble turbulence 0.5; onion;
 *   planar; quilted; quilted control0 0.3 control1 0.8; radial; ripples; ripples frequency 3
 *   phase 0.2; spherical; spiral1 3; spiral2 5; spotted; waves; wood; wood turbulence 0.1;
 *   wrinkles; wrinkles noise_generator 1; bozo turbulence 0.7; bozo turbulence <0.3,0.6,0.9>
 *   octaves 3 omega 0.7 lambda 2.5; bozo warp { turbulence 0.5 octaves 4 }; gradient x warp
 *   { repeat x*2 offset <0,0.5,0> flip x }; gradient x warp { black_hole <0.5,0.5,0.5>, 2
 *   strength 0.8 falloff 1.5 }; gradient y warp { black_hole <0,0,0>, 0.8 repeat <2,2,2>
 *   turbulence <0.3,0.3,0.3> }; gradient y warp { spherical orientation <0,1,0> dist_exp 1 };
 *   gradient x warp { cylindrical }; gradient x warp { toroidal major_radius 2 }; gradient z
 *   warp { planar <1,0,0>, 0.3 }; gradient x warp { cubic }; gradient x scale 2 warp
 *   { turbulence 0.3 } translate 0.1 rotate 30*y turbulence 0.2; gradient x triangle_wave
 *   frequency 1.5 phase 0.2; gradient x scallop_wave / cubic_wave / poly_wave 2.5; gradient x
 *   sine_wave frequency -2; spiral1 2 turbulence 0.3; agate turbulence 0.4. */
static const ref_case cases[] = {
    {"agate", {0.999834494634, 0.497859641484, 0.241759633841, 0.783848179387, 0.899998562460, 0.151665059807, 0.926941358223, 0.007221512330}},
    {"agate_t", {0.564552017225, 0.775694078290, 0.175969610340, 0.017265984349, 0.960725061730, 0.810616442847, 0.102052826416, 0.436819056200}},
    {"boxed", {0.300000000000, 0.000000000000, 0.000000000000, 0.000000000000, 0.950000000000, 0.000000000000, 0.000000000000, 0.000000000000}},
    {"bozo1", {0.545512106734, 0.715572671838, 0.608940197283, 0.504068670006, 0.083955356171, 0.349280367196, 0.184819463315, 0.817533956428}},
    {"bozo2", {0.537828432449, 0.621133590017, 0.568899051756, 0.517527123767, 0.311732171925, 0.441703172767, 0.361141041839, 0.671079918688}},
    {"bozo3", {0.701325860442, 0.756253295383, 0.571348050170, 0.704308692042, 0.530880066794, 0.720626098095, 0.377458943288, 0.191103324033}},
    {"brick", {1.000000000000, 0.000000000000, 0.000000000000, 1.000000000000, 1.000000000000, 1.000000000000, 1.000000000000, 0.000000000000}},
    {"brick2", {1.000000000000, 1.000000000000, 0.000000000000, 1.000000000000, 1.000000000000, 1.000000000000, 1.000000000000, 1.000000000000}},
    {"bumps", {0.537828432449, 0.621133590017, 0.568899051756, 0.517527123767, 0.311732171925, 0.441703172767, 0.361141041839, 0.671079918688}},
    {"cells", {0.711818915326, 0.510565070668, 0.863710861653, 0.806755160913, 0.824241705472, 0.519084190484, 0.554328109138, 0.385360721499}},
    {"checker", {0.000000000000, 1.000000000000, 1.000000000000, 0.000000000000, 1.000000000000, 1.000000000000, 0.000000000000, 1.000000000000}},
    {"crackle", {0.316896193661, 0.240043565535, 0.035929573458, 0.218130115879, 0.105199479311, 0.200545027719, 0.428630718188, 0.534853852301}},
    {"crackle_f", {0.540063752042, 0.477950860480, 0.686698855249, 0.460911970317, 0.673096526109, 0.745384891834, 0.533535373976, 0.340085002606}},
    {"crackle_m1", {0.483783001220, 0.336960359011, 0.157033495652, 0.269876178959, 0.224853884391, 0.281113689067, 0.565491277631, 0.691613504849}},
    {"crackle_m3", {0.284073604709, 0.221232781149, 0.006806779595, 0.203421668571, 0.082068387174, 0.198784422662, 0.318066694590, 0.436927606820}},
    {"crackle_s", {0.432515686947, 0.643923760233, 0.410084359388, 0.420418022581, 0.457736399668, 0.654302981366, 0.496515261411, 0.540064522862}},
    {"cubic", {2.000000000000, 1.000000000000, 0.000000000000, 2.000000000000, 0.000000000000, 0.000000000000, 1.000000000000, 5.000000000000}},
    {"cylindrical", {0.238422689414, 0.000000000000, 0.000000000000, 0.000000000000, 0.949009804864, 0.000000000000, 0.250000000000, 0.000000000000}},
    {"dents", {0.155571941909, 0.239637647614, 0.184121977081, 0.138611527260, 0.030293180753, 0.086177036736, 0.047101044687, 0.302219671868}},
    {"gradient", {0.908688222502, 0.400891862869, 0.244994432064, 0.180408778758, 0.016035674515, 0.690429914629, 0.895325160407, 0.296242142341}},
    {"granite", {0.299106174196, 0.511236317891, 0.594203451597, 0.517827211334, 0.579869829723, 0.350705248803, 0.495415148690, 0.646268375477}},
    {"granite1", {0.351876478235, 0.503238221250, 0.618178122862, 0.487920279525, 0.648364171624, 0.414453935629, 0.557549482717, 0.707560085762}},
    {"hexagon", {0.000000000000, 1.000000000000, 1.000000000000, 1.000000000000, 0.000000000000, 0.000000000000, 0.000000000000, 2.000000000000}},
    {"julia", {1.000000000000, 0.000000000000, 0.000000000000, 0.000000000000, 1.000000000000, 0.000000000000, 0.033333333333, 0.000000000000}},
    {"julia3", {1.000000000000, 0.000000000000, 0.000000000000, 0.000000000000, 1.000000000000, 0.000000000000, 0.000000000000, 0.000000000000}},
    {"julia5", {0.218943941509, 0.042623189278, 0.856290889370, 0.950754724120, 0.026925824036, 0.304738479666, 0.669075547815, 0.506488928796}},
    {"leopard", {0.223780538684, 0.118370685831, 0.069206073822, 0.067237138132, 0.000399706755, 0.815011502108, 0.077261992517, 0.408680696390}},
    {"magnet1m", {1.000000000000, 0.150000000000, 0.350000000000, 0.100000000000, 1.000000000000, 0.050000000000, 0.250000000000, 0.150000000000}},
    {"magnet2j", {1.000000000000, 1.000000000000, 1.000000000000, 1.000000000000, 1.000000000000, 0.100000000000, 1.000000000000, 1.000000000000}},
    {"mandel", {1.000000000000, 0.000000000000, 0.000000000000, 0.000000000000, 1.000000000000, 0.000000000000, 0.040000000000, 0.000000000000}},
    {"mandel4", {1.000000000000, 0.000000000000, 0.000000000000, 0.000000000000, 1.000000000000, 0.000000000000, 0.000000000000, 0.000000000000}},
    {"mandel6", {1.000000000000, 0.861988125000, 0.405668400000, 0.585130624999, 1.000000000000, 0.991472800121, 0.727195600000, 0.415153200001}},
    {"marble", {0.600000000000, 0.499980000000, 0.199940000000, 0.999900000000, 0.100000000000, 0.599800000000, 0.800000000000, 0.399960000000}},
    {"marble_t", {0.265128322624, 0.880251592177, 0.623295062990, 0.072646340295, 0.390314070889, 0.734867294988, 0.695458078790, 0.386929182855}},
    {"onion", {0.911043357914, 0.893959225698, 0.641428291207, 0.412890098158, 0.054772255751, 0.979270367226, 0.500833101980, 0.923681287848}},
    {"planar", {0.500000000000, 0.000000000000, 0.800000000000, 0.000000000000, 0.980000000000, 0.000000000000, 0.000000000000, 0.000000000000}},
    {"quilted", {0.097172754434, 0.140460534255, 0.403687888959, 0.118781385184, 0.543390119263, 0.214742406594, 0.073004196149, 0.174332165292}},
    {"quilted2", {0.044840061060, 0.071418415490, 0.292569884379, 0.057717578095, 0.473361051362, 0.118019317742, 0.031213652746, 0.091119168011}},
    {"radial", {0.814440529205, 0.413989565189, 0.912488148002, 0.647235357937, 0.031406479095, 0.107000765171, 0.602416382350, 0.176198191175}},
    {"ripples", {0.277291559707, 0.419423830711, 0.419411442935, 0.310405341824, 0.522078412816, 0.444407407308, 0.625626844563, 0.502999987438}},
    {"ripples_f", {0.095025765541, 0.906493667820, 0.370627821636, 0.990022067357, 0.017065930968, 0.064009861893, 0.008105471356, 0.672660017753}},
    {"spherical", {0.088956642086, 0.000000000000, 0.000000000000, 0.000000000000, 0.945227744249, 0.000000000000, 0.000000000000, 0.000000000000}},
    {"spiral1", {0.949912229899, 0.467139203299, 0.548733272971, 0.644618615042, 0.048939879085, 0.152036652488, 0.823576777864, 0.306286068546}},
    {"spiral2", {0.920228696226, 0.836515951502, 0.753517692033, 0.563943130155, 0.171189415908, 0.437328862208, 0.823583301732, 0.271670418110}},
    {"spotted", {0.537828432449, 0.621133590017, 0.568899051756, 0.517527123767, 0.311732171925, 0.441703172767, 0.361141041839, 0.671079918688}},
    {"waves", {0.667951258810, 0.506043682278, 0.316097770508, 0.365660142399, 0.641624814912, 0.631575502778, 0.540137365283, 0.621410728385}},
    {"wood", {0.833809621031, 0.409870056251, 0.212829826804, 0.115235675995, 0.107703296143, 0.643101311150, 0.863544212655, 0.067847193979}},
    {"wood_t", {0.262603122637, 0.144894905393, 0.004958328174, 0.266582374392, 0.929751129199, 0.691401133434, 0.885397087618, 0.075427769362}},
    {"wrinkles", {0.573631313623, 0.694804235393, 0.583798123504, 0.542073076713, 0.155168946491, 0.341910829012, 0.262691436698, 0.614499058829}},
    {"wrinkles1", {0.543485689162, 0.667167920568, 0.555197866422, 0.511274651214, 0.116357593458, 0.306966620539, 0.226273566816, 0.585199744132}},
    {"turb", {0.472355127443, 0.676505969786, 0.629209179742, 0.461397528215, 0.501133048916, 0.584045788293, 0.448930138235, 0.671491878556}},
    {"turb_oct", {0.455631451515, 0.580122507318, 0.666042542757, 0.492659249182, 0.599155851590, 0.454799765775, 0.448954663454, 0.656680889214}},
    {"w_turb", {0.499410579255, 0.664633455265, 0.623104108960, 0.476466224853, 0.305916231152, 0.545688763133, 0.397275902759, 0.674774178548}},
    {"w_repeat", {0.300000000000, 0.250000000000, 0.900000000000, 0.500000000000, 0.050000000000, 0.700000000000, 0.600000000000, 0.800000000000}},
    {"w_bh", {0.172711225528, 0.750010000000, 0.100000000000, 0.500050000000, 0.889431003972, 0.300000000000, 0.241100722252, 0.200000000000}},
    {"w_bhrep", {0.500000000000, 0.494181324859, 0.800000000000, 0.750020000000, 0.020000000000, 0.700000000000, 0.300036195848, 0.700030000000}},
    {"w_sph", {0.088956642086, 0.106060774302, 0.358601708793, 0.587199901842, 0.945227744249, 0.020859632774, 0.499176898020, 0.076368712152}},
    {"w_cyl", {0.185559470795, 0.586010434811, 0.087511851998, 0.352764642063, 0.968583520905, 0.892989234829, 0.397583617650, 0.823791808825}},
    {"w_tor", {0.185559470795, 0.586010434811, 0.087511851998, 0.352764642063, 0.968583520905, 0.892989234829, 0.397583617650, 0.823791808825}},
    {"w_plan", {0.700000000000, 0.250000000000, 0.900030000000, 0.500000000000, 0.950000000000, 0.700100000000, 0.600000000000, 0.800020000000}},
    {"w_cubic", {0.428571428571, 0.312500000000, 0.548387096774, 0.280821917808, 0.650000000000, 0.724514563107, 0.317307692308, 0.812500000000}},
    {"w_order", {0.824106544372, 0.607556177253, 0.726842236352, 0.776317217423, 0.680812730283, 0.660088678022, 0.457138802245, 0.916439627050}},
    {"wv_tri", {0.699999994040, 0.650020005960, 0.700000005960, 0.099839994040, 0.550000005960, 0.699999994040, 0.600000005960, 0.999999994040}},
    {"wv_sc", {0.809016994375, 0.707084566423, 0.309016994375, 0.999999987663, 0.156434465040, 0.809016994375, 0.951056516295, 0.587785252292}},
    {"wv_cub", {0.216000000000, 0.843761249850, 0.028000000000, 0.500075000000, 0.007250000000, 0.216000000000, 0.352000000000, 0.104000000000}},
    {"wv_poly", {0.049295030175, 0.487155527767, 0.003162277660, 0.176820892785, 0.000559016994, 0.049295030175, 0.101192885125, 0.017888543820}},
    {"wv_sine", {0.793892626146, 0.500062831853, 0.024471741852, 0.499685840755, 0.206107373854, 0.793892626146, 0.975518549154, 0.206107373854}},
    {"spiral1_t", {0.800140114695, 0.747572956772, 0.238286392548, 0.568933410781, 0.780716634833, 0.318634136161, 0.575291803604, 0.436529330131}},
    {"agate_w", {0.878027077092, 0.932098186580, 0.010799827987, 0.869861180100, 0.941280012117, 0.573279019457, 0.312821077698, 0.022991482778}},
};

/* ---- the cases as pattern descriptions -------------------------------------------------- */

typedef struct built {
    vbnl_pattern_desc d;
    vbnl_warp_desc w[4];
} built;

static void identity(double m[16])
{
    memset(m, 0, 16 * sizeof(double));
    m[0] = m[5] = m[10] = m[15] = 1.0;
}

static vbnl_warp_desc *add_warp(built *b, vbnl_warp_kind kind)
{
    vbnl_warp_desc *w = &b->w[b->d.warp_count++];
    vbnl_warp_desc_init(w);
    w->kind = kind;
    b->d.warps = b->w;
    return w;
}

static void set3(double v[3], double x, double y, double z)
{
    v[0] = x;
    v[1] = y;
    v[2] = z;
}

static void turb(vbnl_turbulence_desc *t, double x, double y, double z)
{
    set3(t->amount, x, y, z);
}

/* Fills b for case `name` as POV-Ray's parser would; 0 for an unknown name. */
static int build(const char *name, built *b)
{
    memset(b, 0, sizeof(*b));
    vbnl_pattern_desc *d = &b->d;
    vbnl_pattern_desc_init(d);
#define IS(s) (!strcmp(name, s))
    if (IS("agate") || IS("agate_t") || IS("agate_w")) {
        d->kind = VBNL_PATTERN_AGATE;
        if (IS("agate_t"))
            d->agate_turb = 0.5;
        if (IS("agate_w"))
            turb(&d->turbulence, 0.4, 0.4, 0.4);
    } else if (IS("boxed")) {
        d->kind = VBNL_PATTERN_BOXED;
    } else if (!strncmp(name, "bozo", 4)) {
        d->kind = VBNL_PATTERN_BOZO;
        d->noise_generator = name[4] - '0';
    } else if (IS("brick") || IS("brick2")) {
        d->kind = VBNL_PATTERN_BRICK;
        d->frequency = 0.0;
        if (IS("brick2")) {
            set3(d->brick.size, 1.0, 0.5, 2.0);
            d->brick.mortar = 0.1;
        }
    } else if (IS("bumps")) {
        d->kind = VBNL_PATTERN_BUMPS;
    } else if (IS("cells")) {
        d->kind = VBNL_PATTERN_CELLS;
    } else if (IS("checker")) {
        d->kind = VBNL_PATTERN_CHECKER;
        d->frequency = 0.0;
    } else if (!strncmp(name, "crackle", 7)) {
        d->kind = VBNL_PATTERN_CRACKLE;
        if (IS("crackle_f"))
            set3(d->crackle.form, 1.0, 0.0, 0.0);
        if (IS("crackle_m1"))
            d->crackle.metric = 1.0;
        if (IS("crackle_m3")) {
            d->crackle.metric = 3.0;
            d->crackle.offset = 0.2;
        }
        if (IS("crackle_s"))
            d->crackle.solid = 1;
    } else if (IS("cubic")) {
        d->kind = VBNL_PATTERN_CUBIC;
        d->frequency = 0.0;
    } else if (IS("cylindrical")) {
        d->kind = VBNL_PATTERN_CYLINDRICAL;
    } else if (IS("dents")) {
        d->kind = VBNL_PATTERN_DENTS;
    } else if (IS("gradient")) {
        d->kind = VBNL_PATTERN_GRADIENT;
        set3(d->gradient.direction, 1.0, 2.0, 3.0);
    } else if (IS("granite") || IS("granite1")) {
        d->kind = VBNL_PATTERN_GRANITE;
        if (IS("granite1"))
            d->noise_generator = 1;
    } else if (IS("hexagon")) {
        d->kind = VBNL_PATTERN_HEXAGON;
        d->frequency = 0.0;
    } else if (!strncmp(name, "julia", 5)) {
        d->kind = VBNL_PATTERN_JULIA;
        d->fractal.coord[0] = 0.353;
        d->fractal.coord[1] = 0.288;
        d->fractal.iterations = 30;
        if (IS("julia3"))
            d->fractal.exponent = 3;
        if (IS("julia5")) {
            d->fractal.exponent = 5;
            d->fractal.interior = 1;
            d->fractal.interior_factor = 0.5;
            d->fractal.exterior = 6;
            d->fractal.exterior_factor = 0.3;
        }
    } else if (IS("leopard")) {
        d->kind = VBNL_PATTERN_LEOPARD;
    } else if (IS("magnet1m") || IS("magnet2j")) {
        d->kind = VBNL_PATTERN_MAGNET;
        d->fractal.iterations = 20;
        d->fractal.magnet = IS("magnet1m") ? 1 : 2;
        if (IS("magnet2j")) {
            d->fractal.julia = 1;
            d->fractal.coord[0] = 0.2;
            d->fractal.coord[1] = 0.3;
        }
    } else if (!strncmp(name, "mandel", 6)) {
        d->kind = VBNL_PATTERN_MANDEL;
        d->fractal.iterations = 25;
        if (IS("mandel4"))
            d->fractal.exponent = 4;
        if (IS("mandel6")) {
            d->fractal.exponent = 6;
            d->fractal.exterior = 3;
            d->fractal.exterior_factor = 0.4;
        }
    } else if (IS("marble") || IS("marble_t")) {
        d->kind = VBNL_PATTERN_MARBLE;
        d->wave = VBNL_WAVE_TRIANGLE;
        if (IS("marble_t"))
            turb(&d->turbulence, 0.5, 0.5, 0.5);
    } else if (IS("onion")) {
        d->kind = VBNL_PATTERN_ONION;
    } else if (IS("planar")) {
        d->kind = VBNL_PATTERN_PLANAR;
    } else if (IS("quilted") || IS("quilted2")) {
        d->kind = VBNL_PATTERN_QUILTED;
        d->frequency = 0.0;
        if (IS("quilted2")) {
            d->quilted.control0 = 0.3;
            d->quilted.control1 = 0.8;
        }
    } else if (IS("radial")) {
        d->kind = VBNL_PATTERN_RADIAL;
    } else if (IS("ripples") || IS("ripples_f")) {
        d->kind = VBNL_PATTERN_RIPPLES;
        if (IS("ripples_f")) {
            d->frequency = 3.0;
            d->phase = 0.2;
        }
    } else if (IS("spherical")) {
        d->kind = VBNL_PATTERN_SPHERICAL;
    } else if (IS("spiral1") || IS("spiral1_t")) {
        d->kind = VBNL_PATTERN_SPIRAL1;
        d->wave = VBNL_WAVE_TRIANGLE;
        d->spiral_arms = IS("spiral1") ? 3 : 2;
        if (IS("spiral1_t"))
            turb(&d->turbulence, 0.3, 0.3, 0.3);
    } else if (IS("spiral2")) {
        d->kind = VBNL_PATTERN_SPIRAL2;
        d->wave = VBNL_WAVE_TRIANGLE;
        d->spiral_arms = 5;
    } else if (IS("spotted")) {
        d->kind = VBNL_PATTERN_SPOTTED;
    } else if (IS("waves")) {
        d->kind = VBNL_PATTERN_WAVES;
    } else if (IS("wood") || IS("wood_t")) {
        d->kind = VBNL_PATTERN_WOOD;
        d->wave = VBNL_WAVE_TRIANGLE;
        if (IS("wood_t"))
            turb(&d->turbulence, 0.1, 0.1, 0.1);
    } else if (IS("wrinkles") || IS("wrinkles1")) {
        d->kind = VBNL_PATTERN_WRINKLES;
        if (IS("wrinkles1"))
            d->noise_generator = 1;
    } else if (IS("turb") || IS("turb_oct") || IS("w_turb")) {
        d->kind = VBNL_PATTERN_BOZO;
        if (IS("turb"))
            turb(&d->turbulence, 0.7, 0.7, 0.7);
        if (IS("turb_oct")) {
            turb(&d->turbulence, 0.3, 0.6, 0.9);
            d->turbulence.octaves = 3;
            d->turbulence.omega = 0.7;
            d->turbulence.lambda = 2.5;
        }
        if (IS("w_turb")) {
            vbnl_warp_desc *w = add_warp(b, VBNL_WARP_TURBULENCE);
            turb(&w->turbulence, 0.5, 0.5, 0.5);
            w->turbulence.octaves = 4;
        }
    } else if (!strncmp(name, "w_", 2) || !strncmp(name, "wv_", 3)) {
        d->kind = VBNL_PATTERN_GRADIENT;
        if (IS("w_repeat")) {
            vbnl_warp_desc *w = add_warp(b, VBNL_WARP_REPEAT);
            w->repeat.axis = 0;
            w->repeat.width = 2.0;
            w->repeat.offset[1] = 0.5;
            w->repeat.flip[0] = 1;
        } else if (IS("w_bh")) {
            vbnl_warp_desc *w = add_warp(b, VBNL_WARP_BLACK_HOLE);
            set3(w->black_hole.center, 0.5, 0.5, 0.5);
            w->black_hole.radius = 2.0;
            w->black_hole.strength = 0.8;
            w->black_hole.falloff = 1.5;
        } else if (IS("w_bhrep")) {
            set3(d->gradient.direction, 0.0, 1.0, 0.0);
            vbnl_warp_desc *w = add_warp(b, VBNL_WARP_BLACK_HOLE);
            /* POV-Ray's parser moves the centre to the radius on a repeated axis (Check_BH_Parameters) */
            set3(w->black_hole.center, 0.8, 0.8, 0.8);
            w->black_hole.radius = 0.8;
            set3(w->black_hole.repeat, 2.0, 2.0, 2.0);
            set3(w->black_hole.turbulence, 0.3, 0.3, 0.3);
        } else if (IS("w_sph")) {
            set3(d->gradient.direction, 0.0, 1.0, 0.0);
            vbnl_warp_desc *w = add_warp(b, VBNL_WARP_SPHERICAL);
            set3(w->mapping.orientation, 0.0, 1.0, 0.0);
            w->mapping.dist_exp = 1.0;
        } else if (IS("w_cyl")) {
            add_warp(b, VBNL_WARP_CYLINDRICAL);
        } else if (IS("w_tor")) {
            add_warp(b, VBNL_WARP_TOROIDAL)->mapping.major_radius = 2.0;
        } else if (IS("w_plan")) {
            set3(d->gradient.direction, 0.0, 0.0, 1.0);
            vbnl_warp_desc *w = add_warp(b, VBNL_WARP_PLANAR);
            set3(w->mapping.orientation, 1.0, 0.0, 0.0);
            w->mapping.offset = 0.3;
        } else if (IS("w_cubic")) {
            add_warp(b, VBNL_WARP_CUBIC);
        } else if (IS("w_order")) {
            /* POV-Ray applies the last transform first: translate 0.1 then rotate 30 y, inverted */
            const double a = 30.0 * M_PI / 180.0, c = cos(a), s = sin(a);
            vbnl_warp_desc *w = add_warp(b, VBNL_WARP_TRANSFORM);
            identity(w->matrix);
            /* forward: x' = x c + z s, z' = -x s + z c (POV-Ray's rotation about y); inverse:
             * the transpose, then minus the translation */
            w->matrix[0] = c, w->matrix[2] = -s, w->matrix[8] = s, w->matrix[10] = c;
            w->matrix[3] = -0.1, w->matrix[7] = -0.1, w->matrix[11] = -0.1;
            vbnl_warp_desc *t = add_warp(b, VBNL_WARP_TURBULENCE);
            turb(&t->turbulence, 0.3, 0.3, 0.3);
            vbnl_warp_desc *sc = add_warp(b, VBNL_WARP_TRANSFORM);
            identity(sc->matrix);
            sc->matrix[0] = sc->matrix[5] = sc->matrix[10] = 0.5;
            turb(&d->turbulence, 0.2, 0.2, 0.2);
        } else if (IS("wv_tri")) {
            d->wave = VBNL_WAVE_TRIANGLE;
            d->frequency = 1.5;
            d->phase = 0.2;
        } else if (IS("wv_sc")) {
            d->wave = VBNL_WAVE_SCALLOP;
        } else if (IS("wv_cub")) {
            d->wave = VBNL_WAVE_CUBIC;
        } else if (IS("wv_poly")) {
            d->wave = VBNL_WAVE_POLY;
            d->exponent = 2.5;
        } else if (IS("wv_sine")) {
            d->wave = VBNL_WAVE_SINE;
            d->frequency = -2.0;
        } else {
            return 0;
        }
    } else {
        return 0;
    }
#undef IS
    return 1;
}

typedef struct fixture {
    vbnl_context *ctx;
    vbnl_scene *scene;
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof(*f));
    vbnl_context_desc d;
    vbnl_context_desc_init(&d);
    d.threads = 1;
    if (!f || vbnl_context_create(&d, &f->ctx, NULL) != VBNL_OK || vbnl_scene_create(f->ctx, &f->scene, NULL) != VBNL_OK)
        return -1;
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    vbnl_scene_destroy(f->scene);
    vbnl_context_destroy(f->ctx);
    free(f);
    return 0;
}

static const vbi_pattern *add_pattern(fixture *f, const vbnl_pattern_desc *d)
{
    uint32_t id;
    vbnl_error err = {0};
    if (vbnl_scene_add_pattern(f->scene, d, &id, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    return &f->scene->tex.patterns[id];
}

static void test_against_povray(void **state)
{
    fixture *f = *state;
    const vbi_texture_set *ts = &f->scene->tex;
    const vbi_shade_point sp = {{0, 0, 0}, {0, 1, 0}, 0, 0, {0, 0, -10}};
    int bad = 0;
    for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); ++c) {
        built b;
        if (!build(cases[c].name, &b))
            fail_msg("no description for case %s", cases[c].name);
        const vbi_pattern *pt = add_pattern(f, &b.d);
        for (int i = 0; i < 8; ++i) {
            double v = vbi_pattern_value(ts, pt, d3(points[i][0], points[i][1], points[i][2]), &sp, NULL);
            double e = cases[c].expect[i];
            if (!(fabs(v - e) <= 1e-9 + 1e-9 * fabs(e))) {
                print_error("%s at point %d: %.12f, POV-Ray %.12f\n", cases[c].name, i, v, e);
                bad++;
            }
        }
    }
    assert_int_equal(bad, 0);
}

/* Tilings 1 to 24 against POV-Ray 3.7.0: `pigment { tiling N color_map { [0 rgb 0] [1 rgb 1] } }`
 * on the plane y = 0, rendered with ambient 1 into a 16-bit linear PNG (one pixel per 0.025):
 * six pixels of each tiling (away from tile borders), their (x, z) and value. */
typedef struct tiling_ref {
    int type;
    double p[6][3];
} tiling_ref;
static const tiling_ref tiling_refs[] = {
    {1, {{2.9875, 3.3625, 0.975006}, {3.7375, 2.7125, 0.474998}, {4.0875, 0.5875, 0.824994}, {4.3875, 0.2625, 0.474998}, {3.1625, -0.9125, 0.824994}, {2.3875, 4.8125, 0.624994}}},
    {2, {{4.3875, 2.0125, 0.774411}, {3.9625, 3.4125, 0.940414}, {3.1625, 4.6625, 0.529397}, {4.7625, 3.9875, 0.604364}, {-0.2875, 2.6125, 0.795834}, {2.0125, -0.5625, 0.649516}}},
    {3, {{0.5875, 2.5625, 0.938384}, {2.6625, 3.4125, 0.910628}, {-0.9125, 0.3125, 0.860624}, {4.8625, -0.5625, 0.219104}, {3.9125, 2.5125, 0.851774}, {0.0125, 0.1125, 0.921324}}},
    {4, {{4.1125, 4.5375, 0.521096}, {-0.1125, 1.0375, 0.603998}, {2.9625, 2.1625, 0.427955}, {-0.1875, 4.1625, 0.612879}, {-0.9875, -0.5875, 0.356771}, {-0.9625, 3.6625, 0.845914}}},
    {5, {{3.9625, 3.6125, 0.251209}, {0.0625, -0.5875, 0.482200}, {0.0625, 3.1375, 0.582620}, {1.0125, 3.7375, 0.236439}, {2.4625, -0.6125, 0.210758}, {3.3375, 0.9875, 0.605097}}},
    {6, {{0.3125, 3.8375, 0.337499}, {3.4125, 3.7375, 0.587503}, {4.7125, 2.5375, 0.212497}, {0.9125, 4.8625, 0.912505}, {1.3125, 2.3375, 0.687495}, {0.0625, -0.9875, 0.487495}}},
    {7, {{-0.0625, 3.3125, 0.691173}, {-0.5875, 2.8875, 0.542977}, {0.9375, -0.2375, 0.730388}, {2.8625, 1.2375, 0.969604}, {-0.9875, 1.1875, 0.169146}, {3.3375, 0.4625, 0.772793}}},
    {8, {{1.1625, 4.5875, 0.833082}, {0.9875, 2.7375, 0.851591}, {4.2375, 3.0375, 0.169833}, {2.0875, 0.5375, 0.898970}, {1.0125, 3.8125, 0.985565}, {2.0875, 1.9875, 0.859739}}},
    {9, {{3.5125, 3.8625, 0.075853}, {-0.6375, 3.3625, 0.882673}, {-0.8625, 0.2125, 0.318517}, {1.2875, -0.4125, 0.666667}, {1.5875, 4.8875, 0.432364}, {2.5125, -0.0375, 0.623362}}},
    {10, {{1.6875, 2.6625, 0.375006}, {1.4125, 1.2875, 0.824994}, {4.3875, 4.9375, 0.874998}, {1.8875, 4.7125, 0.775006}, {3.5375, 3.8375, 0.925002}, {2.9875, 3.7375, 0.474998}}},
    {11, {{-0.2375, 0.1625, 0.558328}, {0.5625, -0.9375, 0.624994}, {4.2375, 2.0375, 0.641672}, {1.2125, 1.7125, 0.191669}, {1.2625, -0.7125, 0.474998}, {2.3625, 3.3875, 0.408331}}},
    {12, {{3.9625, 2.0375, 0.975006}, {-0.3125, 1.2375, 0.791669}, {3.7875, 0.0125, 0.658335}, {4.1125, 2.6375, 0.591669}, {4.5125, 3.1125, 0.591669}, {-0.7625, 2.2375, 0.508339}}},
    {13, {{-0.4125, 3.6625, 0.722240}, {1.1875, 1.7125, 0.000000}, {2.9125, 2.6875, 0.962097}, {4.8875, 4.0625, 0.274647}, {1.1875, 3.2375, 0.385672}, {4.9125, 0.5125, 0.512093}}},
    {14, {{2.4875, 4.4125, 0.007141}, {0.9875, 0.6125, 0.546487}, {1.0375, 3.0375, 0.481727}, {0.1375, -0.1125, 0.790005}, {-0.4875, 0.9875, 0.075776}, {-0.0375, 0.3875, 0.178790}}},
    {15, {{3.4125, 3.0125, 0.500008}, {2.0875, 3.9625, 0.962493}, {3.6125, 4.6875, 0.187503}, {-0.4875, 1.1625, 0.512505}, {2.4125, -0.9125, 0.912505}, {1.5875, 4.7875, 0.500008}}},
    {16, {{0.5125, 0.2625, 0.633280}, {2.8125, 2.7875, 0.951568}, {4.2875, 3.3875, 0.933867}, {1.9125, 0.8375, 0.851621}, {1.6875, 4.0625, 0.666667}, {3.0875, 4.7875, 0.298146}}},
    {17, {{4.1375, 1.8375, 0.150195}, {1.1375, -0.3625, 0.087282}, {0.3375, 4.1625, 0.476020}, {3.6875, 1.3875, 0.000000}, {-0.1625, 0.9625, 0.284138}, {4.7375, -0.0375, 0.486458}}},
    {18, {{1.6375, 4.3125, 0.687495}, {0.0875, 2.2125, 0.412497}, {1.3875, 4.0375, 0.962493}, {-0.6125, -0.4125, 0.612497}, {1.6875, 3.1125, 0.387503}, {-0.0875, 2.0875, 0.912505}}},
    {19, {{4.9125, 1.0375, 0.135332}, {4.4625, 3.9125, 0.129717}, {2.3375, 2.0875, 0.201053}, {2.1125, 0.5875, 0.439979}, {3.6625, 2.9625, 0.952102}, {2.0625, 3.2375, 0.265003}}},
    {20, {{0.8625, 1.9875, 0.666667}, {1.5875, -0.7625, 0.305608}, {-0.0625, 4.2875, 0.617441}, {1.4125, -0.2625, 0.405722}, {2.4125, 3.8625, 0.150851}, {3.0125, -0.9875, 0.526406}}},
    {21, {{2.1875, -0.5625, 0.666667}, {1.1625, 3.8375, 0.439048}, {-0.4375, 1.8625, 0.721263}, {0.7375, 1.7125, 0.895323}, {4.0125, 1.4875, 0.450599}, {4.5625, 1.7875, 0.738521}}},
    {22, {{1.3125, 4.5875, 0.666667}, {4.0375, -0.0875, 0.666667}, {3.9625, 2.7125, 0.969589}, {3.4375, 1.2375, 0.779660}, {3.2375, 4.7875, 0.666667}, {3.8625, 3.0375, 0.442023}}},
    {23, {{1.3375, 1.4125, 0.860670}, {3.5125, 0.7125, 0.362539}, {0.7875, -0.3375, 0.666667}, {2.1125, 3.3125, 0.666667}, {3.9375, 0.5875, 0.525780}, {3.5875, 3.1125, 0.666667}}},
    {24, {{1.1875, 0.8375, 0.454414}, {0.1375, 1.2875, 0.000000}, {4.4625, 4.9375, 0.189364}, {2.0375, 1.4875, 0.800000}, {3.9625, 3.3875, 0.937713}, {1.0875, 0.7125, 0.438987}}},
};

static void test_tilings(void **state)
{
    fixture *f = *state;
    const vbi_texture_set *ts = &f->scene->tex;
    double worst = 0.0;
    for (size_t c = 0; c < sizeof(tiling_refs) / sizeof(tiling_refs[0]); ++c) {
        vbnl_pattern_desc d;
        vbnl_pattern_desc_init(&d);
        d.kind = VBNL_PATTERN_TILING;
        d.tiling = tiling_refs[c].type;
        const vbi_pattern *pt = add_pattern(f, &d);
        for (int i = 0; i < 6; ++i) {
            const double *r = tiling_refs[c].p[i];
            double v = vbi_pattern_value(ts, pt, d3(r[0], 0.0, r[1]), NULL, NULL);
            worst = fmax(worst, fabs(v - r[2]));
            if (!(fabs(v - r[2]) <= 1e-5)) /* the PNG's quantisation: 1 / 131070 */
                fail_msg("tiling %d at (%g, %g): %.6f, POV-Ray %.6f", tiling_refs[c].type, r[0], r[1], v, r[2]);
        }
    }
    print_message("# 24 tilings at 6 points: largest difference from POV-Ray %.2g\n", worst);
    /* the Penrose tilings and pavement are refused */
    vbnl_pattern_desc d;
    vbnl_pattern_desc_init(&d);
    d.kind = VBNL_PATTERN_TILING;
    d.tiling = 25;
    assert_int_equal(vbnl_scene_add_pattern(f->scene, &d, NULL, NULL), VBNL_ERR_INVALID_ARGUMENT);
    d.kind = VBNL_PATTERN_PAVEMENT;
    assert_int_equal(vbnl_scene_add_pattern(f->scene, &d, NULL, NULL), VBNL_ERR_INVALID_ARGUMENT);
}

/* Statistics of the three generators and of turbulence over 200000 points of a large cube. */
static void test_noise_statistics(void **state)
{
    (void)state;
    const vbi_noise_tables *t = vbi_noise_tables_get();
    vbi_rng rng = vbi_rng_for(7, 0, 0);
    const int n = 200000;
    for (int gen = 1; gen <= 3; ++gen) {
        double sum = 0, sum2 = 0, lo = 1, hi = 0;
        for (int i = 0; i < n; ++i) {
            dvec3 p = d3(200.0 * vbi_rng_next(&rng) - 100.0, 200.0 * vbi_rng_next(&rng) - 100.0,
                         200.0 * vbi_rng_next(&rng) - 100.0);
            double v = vbi_noise(t, p, gen);
            sum += v;
            sum2 += v * v;
            lo = fmin(lo, v);
            hi = fmax(hi, v);
        }
        double mean = sum / n, sd = sqrt(sum2 / n - mean * mean);
        print_message("# generator %d: mean %.4f, sd %.4f, range [%.4f, %.4f]\n", gen, mean, sd, lo, hi);
        /* values fill [0, 1] (clamped), centred near one half: generator 3's mean is 0.49 by
         * POV-Ray's note on its bias correction */
        assert_true(lo >= 0.0 && hi <= 1.0 && lo < 0.05 && hi > 0.95);
        assert_true(fabs(mean - 0.5) < 0.03);
        assert_true(gen != 3 || fabs(mean - 0.49) < 0.01);
        assert_true(sd > 0.1 && sd < 0.3);
    }
    /* the gradient noise has zero mean in each component, and turbulence of n octaves with omega
     * 1/2 stays below 2 - 2^(1-n) times the first octave's range */
    dvec3 acc = d3(0, 0, 0);
    vbi_turb tb = {{1, 1, 1}, 6, 0.5, 2.0};
    double tmax = 0;
    for (int i = 0; i < n; ++i) {
        dvec3 p = d3(100.0 * vbi_rng_next(&rng), 100.0 * vbi_rng_next(&rng), 100.0 * vbi_rng_next(&rng));
        acc = d3_add(acc, vbi_dnoise(t, p));
        tmax = fmax(tmax, vbi_turbulence(t, p, &tb, 1));
    }
    print_message("# dnoise mean (%.4f %.4f %.4f), turbulence max %.3f\n", acc.x / n, acc.y / n, acc.z / n, tmax);
    assert_true(fabs(acc.x / n) < 0.02 && fabs(acc.y / n) < 0.02 && fabs(acc.z / n) < 0.02);
    assert_true(tmax <= 2.0 - 1.0 / 32.0 && tmax > 1.0);
}

/* The tables: the hash is a permutation of 0..4095 repeated; the pattern random numbers are
 * MT19937's reference outputs (the first is 3499211612 / 2^32) with mean 1/2. */
static void test_tables(void **state)
{
    (void)state;
    const vbi_noise_tables *t = vbi_noise_tables_get();
    int seen[4096] = {0};
    for (int i = 0; i < 4096; ++i) {
        assert_true(t->hash[i] < 4096);
        seen[t->hash[i]]++;
        assert_int_equal(t->hash[i], t->hash[4096 + i]);
    }
    for (int i = 0; i < 4096; ++i)
        assert_int_equal(seen[i], 1);
    assert_true(t->rands[0] == 3499211612.0 / 4294967296.0);
    assert_true(t->rands[1] == 581869302.0 / 4294967296.0);
    double m = 0;
    for (int i = 0; i < VBI_PATTERN_RANDS; ++i)
        m += t->rands[i];
    assert_true(fabs(m / VBI_PATTERN_RANDS - 0.5) < 0.01);
    /* the gradients of generator 3 are unit vectors */
    for (int i = 0; i < VBI_NOISE_SOLID_SIZE; ++i) {
        const double *g = t->solid_grad[i];
        assert_true(fabs(g[0] * g[0] + g[1] * g[1] + g[2] * g[2] - 1.0) < 1e-12);
    }
}

/* The waves: POV-Ray's cycloidal is sin(2 pi v) and the triangle wave of period 1. */
static void test_waves(void **state)
{
    (void)state;
    for (double v = -3.0; v <= 3.0; v += 0.0625) {
        assert_true(fabs(vbi_cycloidal(v) - sin(2.0 * M_PI * v)) < 1e-12);
        double f = v - floor(v), tri = f < 0.5 ? 2.0 * f : 2.0 * (1.0 - f);
        assert_true(fabs(vbi_triangle_wave(v) - tri) < 1e-12);
    }
}

static void expect_error(fixture *f, const vbnl_pattern_desc *d, const char *text)
{
    vbnl_error err = {0};
    assert_int_equal(vbnl_scene_add_pattern(f->scene, d, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    if (!strstr(err.message, text))
        fail_msg("error '%s' lacks '%s'", err.message, text);
}

static void test_validation(void **state)
{
    fixture *f = *state;
    vbnl_pattern_desc d;
    vbnl_pattern_desc_init(&d);
    d.size = 8;
    expect_error(f, &d, "size");
    vbnl_pattern_desc_init(&d);
    d.kind = VBNL_PATTERN_KIND_COUNT;
    expect_error(f, &d, "unknown pattern kind");
    vbnl_pattern_desc_init(&d);
    d.noise_generator = 4;
    expect_error(f, &d, "noise_generator");
    vbnl_pattern_desc_init(&d);
    d.transform[0] = 0.0f;
    expect_error(f, &d, "singular");
    vbnl_pattern_desc_init(&d);
    d.kind = VBNL_PATTERN_GRADIENT;
    set3(d.gradient.direction, 0, 0, 0);
    expect_error(f, &d, "gradient");
    vbnl_pattern_desc_init(&d);
    d.kind = VBNL_PATTERN_MANDEL;
    d.fractal.exponent = 40;
    expect_error(f, &d, "exponent");
    vbnl_pattern_desc_init(&d);
    d.kind = VBNL_PATTERN_IMAGE;
    d.image.image = 3;
    expect_error(f, &d, "no image");
    vbnl_pattern_desc_init(&d);
    d.kind = VBNL_PATTERN_TILING;
    d.tiling = 28;
    expect_error(f, &d, "tiling");
    vbnl_pattern_desc_init(&d);
    vbnl_warp_desc w;
    vbnl_warp_desc_init(&w);
    w.kind = VBNL_WARP_REPEAT;
    d.warps = &w;
    d.warp_count = 1;
    expect_error(f, &d, "repeat");
    w.kind = VBNL_WARP_BLACK_HOLE;
    w.black_hole.radius = -1.0f;
    expect_error(f, &d, "black_hole");
    d.warp_count = VBNL_TEXTURE_WARP_MAX + 1;
    expect_error(f, &d, "warps");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_against_povray, setup, teardown),
        cmocka_unit_test_setup_teardown(test_tilings, setup, teardown),
        cmocka_unit_test(test_noise_statistics),
        cmocka_unit_test(test_tables),
        cmocka_unit_test(test_waves),
        cmocka_unit_test_setup_teardown(test_validation, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
