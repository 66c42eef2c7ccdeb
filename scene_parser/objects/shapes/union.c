/* vbnl object layer: union { objects and modifiers } and light_group (a union whose lights
 * light the whole scene). The members' primitives join the union's list. */
#include "pov_shape.h"

static int member(const pov_item *it)
{
    if (!pov_is_shape(it->tok))
        return 0;
    return pov_parse_member(it->ctx, ((pov_mods *)it->target)->o) == VBNL_OK ? 1 : -1;
}

static const pov_row light_group_rows[] = {{"global_lights", pov_item_any_bool, 0}, {NULL, NULL, 0}};
static const pov_row *const union_tables[] = {pov_transform_rows, pov_modifier_rows, NULL};
static const pov_row *const light_group_tables[] = {light_group_rows, pov_transform_rows, pov_modifier_rows, NULL};

static const pov_block union_block = {.tables = union_tables,
                                      .before = pov_modifier_appearance,
                                      .after = member,
                                      .transform = pov_modifier_transform};
static const pov_block light_group_block = {.tables = light_group_tables,
                                            .before = pov_modifier_appearance,
                                            .after = member,
                                            .transform = pov_modifier_transform};

vbnl_result pov_shape_union(const pov_shape *s)
{
    int light_group = s->keyword[0] == 'l';
    if (light_group)
        vbnl_sdl_warning(s->L->c.parser, &s->loc, "light_group is rendered as a union: its lights illuminate the whole scene");
    pov_mods m = {s->L, s->o, 0, 0, {0}, {0}};
    return pov_block_parse(light_group ? &light_group_block : &union_block, s->L->c.parser, s->L, &m, s->keyword);
}
