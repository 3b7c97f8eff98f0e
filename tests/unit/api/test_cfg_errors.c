/* Error reporting of the cfg scene reader (api/scene/cfg_parse.h) against the
 * "Errors" section of scene-format.md: every class of bad input gives one
 * error with the right code, line, column and exact message, and nothing
 * else (no crash, no leak, a scene that frees cleanly).
 *
 * Lines and columns in the table were counted by hand from the text:
 * 1-based, columns in characters (so "ø" is one column). Each row is also
 * run with CRLF line ends, with a UTF-8 BOM, and with both; the spec accepts
 * those spellings, so the message must not change. */
#include <criterion/criterion.h>
#include <criterion/parameterized.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cfg_parse.h"
#include "rayd/scene.h"
#include "scene_limits.h"
#include "scene_load.h"

/* A reader that loops forever fails its test instead of hanging the suite. */
TestSuite(cfg_errors, .timeout = 60);

/* The expected message holds one %zu for the input's length in bytes, which
 * the CRLF and BOM variants change. */
#define F_BYTES 1

struct row {
    const char *name;
    const char *text;
    size_t len;
    rd_error_code code;
    int line, column;
    const char *message;
    size_t lim_field; /* offsetof(rd_scene_limits, ...) to lower, when lim_value > 0 */
    size_t lim_value;
    int flags;
};

/* sizeof, not strlen: some texts carry NUL bytes. */
#define ROW(n, t, c, l, col, m)                                                                                        \
    {                                                                                                                  \
        n, t, sizeof(t) - 1, c, l, col, m, 0, 0, 0                                                                     \
    }
/* The default limits with one field set to val. */
#define ROWL(n, t, c, l, col, m, field, val, fl)                                                                       \
    {                                                                                                                  \
        n, t, sizeof(t) - 1, c, l, col, m, offsetof(rd_scene_limits, field), val, fl                                   \
    }

#define SYN RD_ERR_SYNTAX
#define INV RD_ERR_INVALID
#define LIM RD_ERR_LIMIT

/* The example of scene-format.md, cut where rows change a line. */
#define SPEC_1_2 "# phong.cfg: three Phong spheres on a diffuse floor\n[render]\n"
#define SPEC_3 "width = 640\n"
#define SPEC_4_19                                                                                                      \
    "height = 480\n\n[camera]\neye = 0 2 8\ntarget = 0 1 0\nfov = 45\n\n[light key]\n"                                 \
    "type = point\nposition = 5 8 5\ncolor = 1 1 1\n\n[material red]\ntype = phong\n"                                  \
    "kd = 0.6 0.1 0.1\nks = 0.4 0.4 0.4\n"
#define SPEC_20 "shininess = 50\n"
#define SPEC_21_31                                                                                                     \
    "ambient = 0.05 0.05 0.05\n\n[sphere]\ncenter = 0 1 0\nradius = 1\nmaterial = red\n\n"                             \
    "[plane]\npoint = 0 0 0\nnormal = 0 1 0\nmaterial = floor\n"

#define MAT_LIST                                                                                                       \
    "diffuse, phong, blinn_phong, cook_torrance, perfect_specular, specular_refraction, "                              \
    "pseudo_normal_color, textured_phong"

static const struct row rows[] = {
    /* ---- syntax ---- */
    ROW("header_missing_bracket", "[render\nwidth = 1\n", SYN, 1, 8,
        "t.cfg:1:8: missing ']' at the end of the section header"),
    ROW("header_missing_bracket_named", "[render]\n[material red\n", SYN, 2, 14,
        "t.cfg:2:14: missing ']' at the end of the section header"),
    ROW("header_comment_before_bracket", "[camera # c\n", SYN, 1, 9, "t.cfg:1:9: expected ']' after the section name"),
    ROW("header_empty", "[]\n", SYN, 1, 2, "t.cfg:1:2: expected a section kind after '['"),
    ROW("header_only_spaces", "[  ]\n", SYN, 1, 4, "t.cfg:1:4: expected a section kind after '['"),
    ROW("header_two_names", "[light key fill]\n", SYN, 1, 12, "t.cfg:1:12: expected ']' after the section name"),
    ROW("header_bad_name_char", "[material red!]\n", SYN, 1, 14, "t.cfg:1:14: expected ']' after the section name"),
    ROW("text_after_header", "[render] width = 1\n", SYN, 1, 10,
        "t.cfg:1:10: unexpected text after the section header"),
    /* ø is two bytes but one column. */
    ROW("text_after_header_utf8_name", "[material rød] x\n", SYN, 1, 16,
        "t.cfg:1:16: unexpected text after the section header"),
    ROW("text_after_header_double_bracket", "[render]]\n", SYN, 1, 9,
        "t.cfg:1:9: unexpected text after the section header"),
    ROW("no_equals", "[render]\nwidth 640\n", SYN, 2, 7, "t.cfg:2:7: expected '=' after key 'width'"),
    ROW("no_equals_end_of_line", "[render]\nwidth\n", SYN, 2, 6, "t.cfg:2:6: expected '=' after key 'width'"),
    ROW("no_equals_comment", "[render]\nwidth # = 5\n", SYN, 2, 7, "t.cfg:2:7: expected '=' after key 'width'"),
    ROW("key_colon", "[render]\nwidth: 640\n", SYN, 2, 1, "t.cfg:2:1: expected '[section]' or 'key = value'"),
    ROW("key_dash", "[render]\nmax-depth = 3\n", SYN, 2, 1, "t.cfg:2:1: expected '[section]' or 'key = value'"),
    ROW("key_non_ascii", "[render]\nwïdth = 3\n", SYN, 2, 1, "t.cfg:2:1: expected '[section]' or 'key = value'"),
    ROW("key_quoted", "[render]\n\"width\" = 3\n", SYN, 2, 1, "t.cfg:2:1: expected '[section]' or 'key = value'"),
    ROW("key_missing", "[render]\n = 3\n", SYN, 2, 2, "t.cfg:2:2: expected '[section]' or 'key = value'"),
    ROW("key_outside_section", "width = 640\n[render]\n", SYN, 1, 1,
        "t.cfg:1:1: key 'width' outside any section; start one with a header such as [render]"),
    ROW("key_outside_section_after_comments", "# hi\n\n  eye = 0 0 1\n", SYN, 3, 3,
        "t.cfg:3:3: key 'eye' outside any section; start one with a header such as [render]"),
    ROW("unterminated_string_value", "[sphere]\nmaterial = \"red\n", SYN, 2, 12, "t.cfg:2:12: unterminated string"),
    ROW("unterminated_string_header", "[material \"red]\n", SYN, 1, 11, "t.cfg:1:11: unterminated string"),
    /* '#' inside quotes is not a comment, so the string never closes. */
    ROW("unterminated_string_hash", "[material m]\ntype = textured_phong\ntexture = \"a # b\n", SYN, 3, 11,
        "t.cfg:3:11: unterminated string"),
    ROW("text_after_closing_quote", "[sphere]\nmaterial = \"red\"x\n", SYN, 2, 17,
        "t.cfg:2:17: expected a space after the closing quote"),
    /* ø is one column even where the byte count would say two. */
    ROW("text_after_closing_quote_utf8", "[sphere]\nmaterial = \"ø\"x\n", SYN, 2, 15,
        "t.cfg:2:15: expected a space after the closing quote"),
    ROW("empty_texture", "[material t]\ntype = textured_phong\ntexture = \"\"\n", SYN, 3, 11,
        "t.cfg:3:11: texture: must not be empty"),
    ROW("empty_quoted_name", "[sphere]\nmaterial = \"\"\n", SYN, 2, 12, "t.cfg:2:12: material: must not be empty"),

    /* ---- unknown section kind ---- */
    ROW("section_typo", "[sphre]\n", SYN, 1, 1, "t.cfg:1:1: unknown section kind 'sphre'; did you mean 'sphere'?"),
    ROW("section_transposed", "[render]\nwidth = 1\n\n  [materail red]\n", SYN, 4, 3,
        "t.cfg:4:3: unknown section kind 'materail'; did you mean 'material'?"),
    ROW("section_capital", "[Light key]\n", SYN, 1, 1,
        "t.cfg:1:1: unknown section kind 'Light'; did you mean 'light'?"),
    ROW("section_plural", "[lights]\n", SYN, 1, 1, "t.cfg:1:1: unknown section kind 'lights'; did you mean 'light'?"),
    ROW("section_unknown", "[foo]\n", SYN, 1, 1, "t.cfg:1:1: unknown section kind 'foo'"),
    /* Three edits from "camera" is too far to guess. */
    ROW("section_too_far", "[cam]\neye = 0 0 1\n", SYN, 1, 1, "t.cfg:1:1: unknown section kind 'cam'"),

    /* ---- unknown key ---- */
    ROW("spec_shinyness", SPEC_1_2 SPEC_3 SPEC_4_19 "shinyness = 50\n" SPEC_21_31, SYN, 20, 1,
        "t.cfg:20:1: unknown key 'shinyness' in [material red]; did you mean 'shininess'?"),
    ROW("shinyness_short", "[material red]\ntype = phong\nshinyness = 50\n", SYN, 3, 1,
        "t.cfg:3:1: unknown key 'shinyness' in [material red]; did you mean 'shininess'?"),
    ROW("key_transposed", "[render]\nwidht = 5\n", SYN, 2, 1,
        "t.cfg:2:1: unknown key 'widht' in [render]; did you mean 'width'?"),
    ROW("key_capital", "[render]\nWidth = 5\n", SYN, 2, 1,
        "t.cfg:2:1: unknown key 'Width' in [render]; did you mean 'width'?"),
    ROW("key_indented_named_sphere", "[sphere ball]\n  radus = 1\n", SYN, 2, 3,
        "t.cfg:2:3: unknown key 'radus' in [sphere ball]; did you mean 'radius'?"),
    ROW("key_british", "[light]\ncolour = 1 1 1\n", SYN, 2, 1,
        "t.cfg:2:1: unknown key 'colour' in [light]; did you mean 'color'?"),
    ROW("key_plane_typo", "[plane]\nnormale = 0 1 0\n", SYN, 2, 1,
        "t.cfg:2:1: unknown key 'normale' in [plane]; did you mean 'normal'?"),
    ROW("key_no_suggestion", "[camera]\nlook_at = 0 0 0\n", SYN, 2, 1, "t.cfg:2:1: unknown key 'look_at' in [camera]"),
    /* One edit in a two-letter key is half the word: not a likely typo. */
    ROW("key_short_no_suggestion", "[triangle]\nv3 = 0 0 0\n", SYN, 2, 1, "t.cfg:2:1: unknown key 'v3' in [triangle]"),
    /* Three edits in a ten-letter word: past the limit of two. */
    ROW("key_three_edits", "[render]\nbckgrnd = 0 0 0\n", SYN, 2, 1, "t.cfg:2:1: unknown key 'bckgrnd' in [render]"),
    ROW("key_of_other_section", "[render]\nfov = 45\n", SYN, 2, 1, "t.cfg:2:1: unknown key 'fov' in [render]"),

    /* ---- key not applicable to the material or light type ---- */
    ROW("ks_on_diffuse", "[material m]\ntype = diffuse\nks = 1 1 1\n", SYN, 3, 1,
        "t.cfg:3:1: key 'ks' does not apply to a diffuse material in [material m]"),
    /* The type decides even when written after the key. */
    ROW("shininess_before_cook_torrance", "[material m]\nshininess = 5\ntype = cook_torrance\n", SYN, 2, 1,
        "t.cfg:2:1: key 'shininess' does not apply to a cook_torrance material in [material m]"),
    ROW("kd_on_pseudo_normal", "[material n]\ntype = pseudo_normal_color\nkd = 1 0 0\n", SYN, 3, 1,
        "t.cfg:3:1: key 'kd' does not apply to a pseudo_normal_color material in [material n]"),
    ROW("roughness_on_mirror", "[material mirror]\ntype = perfect_specular\nroughness = 0.5\n", SYN, 3, 1,
        "t.cfg:3:1: key 'roughness' does not apply to a perfect_specular material in [material mirror]"),
    ROW("position_on_directional", "[light]\ntype = directional\nposition = 0 1 0\ndirection = 0 -1 0\n", SYN, 3, 1,
        "t.cfg:3:1: key 'position' does not apply to a directional light in [light]"),
    /* No type means point. */
    ROW("samples_on_default_point", "[light sun]\nsamples = 4\nposition = 0 0 0\n", SYN, 2, 1,
        "t.cfg:2:1: key 'samples' does not apply to a point light in [light sun]"),
    ROW("corner_on_spot", "[light s]\ntype = spot\nposition = 0 1 0\ndirection = 0 -1 0\ncorner = 0 0 0\n", SYN, 5, 1,
        "t.cfg:5:1: key 'corner' does not apply to a spot light in [light s]"),

    /* ---- duplicate key ---- */
    ROW("duplicate_width", "[render]\nwidth = 1\nwidth = 2\n", SYN, 3, 1,
        "t.cfg:3:1: duplicate key 'width' in [render] (first at line 2)"),
    ROW("duplicate_type", "[material red]\ntype = phong\nkd = 1 1 1\ntype = diffuse\n", SYN, 4, 1,
        "t.cfg:4:1: duplicate key 'type' in [material red] (first at line 2)"),
    ROW("duplicate_indented", "[sphere]\ncenter = 0 0 0\n\tradius = 1\n  radius=2\n", SYN, 4, 3,
        "t.cfg:4:3: duplicate key 'radius' in [sphere] (first at line 3)"),

    /* ---- duplicate name or section ---- */
    ROW("duplicate_material", "[material red]\ntype = diffuse\n[material red]\ntype = phong\n", SYN, 3, 1,
        "t.cfg:3:1: duplicate material name 'red' (first at line 1)"),
    /* Quotes are spelling, not part of the name. */
    ROW("duplicate_material_quoted", "[material \"red\"]\ntype = diffuse\n\n[material red]\ntype = diffuse\n", SYN, 4,
        1, "t.cfg:4:1: duplicate material name 'red' (first at line 1)"),
    ROW("duplicate_light", "[light key]\nposition = 0 0 0\n[light key]\nposition = 1 1 1\n", SYN, 3, 1,
        "t.cfg:3:1: duplicate light name 'key' (first at line 1)"),
    ROW("duplicate_render", "[render]\n[camera]\n[render]\n", SYN, 3, 1,
        "t.cfg:3:1: duplicate [render] section (first at line 1)"),
    ROW("duplicate_camera", "\n[camera]\neye = 0 0 1\n# again\n [camera]\n", SYN, 5, 2,
        "t.cfg:5:2: duplicate [camera] section (first at line 2)"),
    ROW("render_with_name", "[render main]\n", SYN, 1, 1, "t.cfg:1:1: [render] takes no name"),
    ROW("material_without_name", "[material]\ntype = diffuse\n", SYN, 1, 1,
        "t.cfg:1:1: [material] needs a name, as in [material red]"),
    ROW("material_empty_name", "[material \"\"]\ntype = diffuse\n", SYN, 1, 1,
        "t.cfg:1:1: [material] needs a name, as in [material red]"),

    /* ---- arity ---- */
    ROW("vec3_two", "[camera]\neye = 0 1\n", SYN, 2, 7, "t.cfg:2:7: eye: expected 3 numbers, got 2"),
    ROW("vec3_four", "[camera]\ntarget = 0 1 2 3\n", SYN, 2, 10, "t.cfg:2:10: target: expected 3 numbers, got 4"),
    /* More tokens than the reader keeps (8) must still be counted. */
    ROW("vec3_ten", "[camera]\neye = 1 2 3 4 5 6 7 8 9 10\n", SYN, 2, 7, "t.cfg:2:7: eye: expected 3 numbers, got 10"),
    ROW("vec3_none", "[render]\nbackground =\n", SYN, 2, 13, "t.cfg:2:13: background: expected 3 numbers, got 0"),
    ROW("vec3_only_comment", "[render]\nbackground = # none\n", SYN, 2, 14,
        "t.cfg:2:14: background: expected 3 numbers, got 0"),
    ROW("vec2_three", "[triangle]\nuv0 = 0 0 0\n", SYN, 2, 7, "t.cfg:2:7: uv0: expected 2 numbers, got 3"),
    ROW("real_two", "[sphere]\nradius = 1 2\n", SYN, 2, 10, "t.cfg:2:10: radius: expected a number, got 2 values"),
    ROW("int_two", "[render]\nwidth = 640 480\n", SYN, 2, 9, "t.cfg:2:9: width: expected an integer, got 2 values"),
    ROW("seed_none", "[render]\nseed =\n", SYN, 2, 7, "t.cfg:2:7: seed: expected an integer, got 0 values"),
    ROW("name_two_words", "[sphere]\nmaterial = red blue\n", SYN, 2, 12,
        "t.cfg:2:12: material: expected a name, got 2 values"),
    ROW("enum_two_words", "[light]\ntype = point light\n", SYN, 2, 8, "t.cfg:2:8: type: expected a word, got 2 values"),
    ROW("name_none", "[sphere]\nmaterial =\n", SYN, 2, 11, "t.cfg:2:11: material: expected a name, got 0 values"),
    ROW("enum_none", "[material m]\ntype =   # later\n", SYN, 2, 10, "t.cfg:2:10: type: expected a word, got 0 values"),
    ROW("string_two_words", "[material m]\ntype = textured_phong\ntexture = a.png b.png\n", SYN, 3, 11,
        "t.cfg:3:11: texture: expected a string, got 2 values"),

    /* ---- wrong type ---- */
    ROW("spec_width_64O", SPEC_1_2 "width = 64O\n" SPEC_4_19 SPEC_20 SPEC_21_31, SYN, 3, 9,
        "t.cfg:3:9: width: expected an integer in 1..16384, got '64O'"),
    ROW("width_64O", "[render]\nwidth = 64O\n", SYN, 2, 9,
        "t.cfg:2:9: width: expected an integer in 1..16384, got '64O'"),
    ROW("height_real", "[render]\nheight = 480.0\n", SYN, 2, 10,
        "t.cfg:2:10: height: expected an integer in 1..16384, got '480.0'"),
    /* Control bytes are shown as '?' so the message stays printable. */
    ROW("width_control_byte",
        "[render]\nwidth = 6\x01"
        "4\n",
        SYN, 2, 9, "t.cfg:2:9: width: expected an integer in 1..16384, got '6?4'"),
    ROW("width_long_token", "[render]\nwidth = 11111111111111111111111111111111111111111111111111\n", SYN, 2, 9,
        "t.cfg:2:9: width: expected an integer in 1..16384, got '1111111111111111111111111111111111111111...'"),
    ROW("fov_word", "[camera]\nfov = wide\n", SYN, 2, 7, "t.cfg:2:7: fov: expected a number in (0, 180), got 'wide'"),
    ROW("fov_hex", "[camera]\nfov = 0x10\n", SYN, 2, 7, "t.cfg:2:7: fov: expected a number in (0, 180), got '0x10'"),
    ROW("eye_word", "[camera]\neye = 0 one 2\n", SYN, 2, 9, "t.cfg:2:9: eye: expected a number, got 'one'"),
    ROW("eye_trailing_e", "[camera]\neye = 0 0 1e\n", SYN, 2, 11, "t.cfg:2:11: eye: expected a number, got '1e'"),
    /* A quoted "45" is a string: showing it without its quotes would make
     * "expected a number, got '45'" contradict itself. */
    ROW("fov_quoted_number", "[camera]\nfov = \"45\"\n", SYN, 2, 7,
        "t.cfg:2:7: fov: expected a number in (0, 180), got the string \"45\""),
    ROW("material_type_unknown", "[material m]\ntype = plastic\n", SYN, 2, 8,
        "t.cfg:2:8: type: expected one of " MAT_LIST ", got 'plastic'"),
    ROW("material_type_typo", "[material m]\ntype = phnog\n", SYN, 2, 8,
        "t.cfg:2:8: type: expected one of " MAT_LIST ", got 'phnog'; did you mean 'phong'?"),
    ROW("light_type_unknown", "[light]\ntype = sun\n", SYN, 2, 8,
        "t.cfg:2:8: type: expected one of point, directional, spot, area, got 'sun'"),
    ROW("light_type_capital", "[light]\ntype = Spot\n", SYN, 2, 8,
        "t.cfg:2:8: type: expected one of point, directional, spot, area, got 'Spot'; did you mean 'spot'?"),
    ROW("seed_negative", "[render]\nseed = -1\n", SYN, 2, 8,
        "t.cfg:2:8: seed: expected an integer in 0..18446744073709551615, got '-1'"),
    ROW("seed_2_pow_64", "[render]\nseed = 18446744073709551616\n", SYN, 2, 8,
        "t.cfg:2:8: seed: expected an integer in 0..18446744073709551615, got '18446744073709551616'"),
    ROW("seed_real", "[render]\nseed = 1.5\n", SYN, 2, 8,
        "t.cfg:2:8: seed: expected an integer in 0..18446744073709551615, got '1.5'"),

    /* ---- out of range ---- */
    ROW("width_0", "[render]\nwidth = 0\n", SYN, 2, 9, "t.cfg:2:9: width: expected an integer in 1..16384, got '0'"),
    /* A tab is one character, hence one column. */
    ROW("width_0_after_tab", "[render]\n\twidth =\t0\n", SYN, 2, 10,
        "t.cfg:2:10: width: expected an integer in 1..16384, got '0'"),
    ROW("width_16385", "[render]\nwidth = 16385\n", SYN, 2, 9,
        "t.cfg:2:9: width: expected an integer in 1..16384, got '16385'"),
    /* Past long long: must not wrap into range. */
    ROW("width_huge", "[render]\nwidth = 99999999999999999999\n", SYN, 2, 9,
        "t.cfg:2:9: width: expected an integer in 1..16384, got '99999999999999999999'"),
    ROW("height_negative", "[render]\nheight = -1\n", SYN, 2, 10,
        "t.cfg:2:10: height: expected an integer in 1..16384, got '-1'"),
    ROW("samples_65537", "[render]\nsamples = 65537\n", SYN, 2, 11,
        "t.cfg:2:11: samples: expected an integer in 1..65536, got '65537'"),
    ROW("samples_0", "[render]\nsamples = 0\n", SYN, 2, 11,
        "t.cfg:2:11: samples: expected an integer in 1..65536, got '0'"),
    ROW("max_depth_65", "[render]\nmax_depth = 65\n", SYN, 2, 13,
        "t.cfg:2:13: max_depth: expected an integer in 0..64, got '65'"),
    ROW("max_depth_negative", "[render]\nmax_depth = -1\n", SYN, 2, 13,
        "t.cfg:2:13: max_depth: expected an integer in 0..64, got '-1'"),
    ROW("fov_0", "[camera]\nfov = 0\n", SYN, 2, 7, "t.cfg:2:7: fov: expected a number in (0, 180), got '0'"),
    ROW("fov_180", "[camera]\nfov = 180\n", SYN, 2, 7, "t.cfg:2:7: fov: expected a number in (0, 180), got '180'"),
    ROW("fov_negative", "[camera]\nfov = -10\n", SYN, 2, 7, "t.cfg:2:7: fov: expected a number in (0, 180), got '-10'"),
    ROW("gamma_0", "[render]\ngamma = 0\n", SYN, 2, 9, "t.cfg:2:9: gamma: expected a number > 0, got '0'"),
    ROW("gamma_negative", "[render]\ngamma = -2.2\n", SYN, 2, 9, "t.cfg:2:9: gamma: expected a number > 0, got '-2.2'"),
    ROW("spot_angle_91", "[light s]\ntype = spot\nposition = 0 0 0\ndirection = 0 -1 0\nangle = 91\n", SYN, 5, 9,
        "t.cfg:5:9: angle: expected a number in (0, 90], got '91'"),
    ROW("spot_angle_0", "[light s]\ntype = spot\nposition = 0 0 0\ndirection = 0 -1 0\nangle = 0\n", SYN, 5, 9,
        "t.cfg:5:9: angle: expected a number in (0, 90], got '0'"),
    ROW("spot_falloff_negative", "[light s]\ntype = spot\nposition = 0 0 0\ndirection = 0 -1 0\nfalloff = -1\n", SYN, 5,
        11, "t.cfg:5:11: falloff: expected a number >= 0, got '-1'"),
    ROW("roughness_0", "[material m]\ntype = cook_torrance\nroughness = 0\n", SYN, 3, 13,
        "t.cfg:3:13: roughness: expected a number in (0, 1], got '0'"),
    ROW("roughness_1_5", "[material m]\ntype = cook_torrance\nroughness = 1.5\n", SYN, 3, 13,
        "t.cfg:3:13: roughness: expected a number in (0, 1], got '1.5'"),
    ROW("ior_0", "[material glass]\ntype = specular_refraction\nior = 0\n", SYN, 3, 7,
        "t.cfg:3:7: ior: expected a number > 0, got '0'"),
    ROW("shininess_negative", "[material m]\ntype = phong\nshininess = -1\n", SYN, 3, 13,
        "t.cfg:3:13: shininess: expected a number >= 0, got '-1'"),
    ROW("uv_scale_0", "[material t]\ntype = textured_phong\ntexture = t.png\nuv_scale = 0\n", SYN, 4, 12,
        "t.cfg:4:12: uv_scale: expected a number > 0, got '0'"),
    ROW("area_samples_65", "[light a]\ntype = area\ncorner = 0 0 0\nedge1 = 1 0 0\nedge2 = 0 0 1\nsamples = 65\n", SYN,
        6, 11, "t.cfg:6:11: samples: expected an integer in 1..64, got '65'"),
    ROW("area_samples_0", "[light a]\ntype = area\ncorner = 0 0 0\nedge1 = 1 0 0\nedge2 = 0 0 1\nsamples = 0\n", SYN, 6,
        11, "t.cfg:6:11: samples: expected an integer in 1..64, got '0'"),

    /* ---- NaN and infinity ---- */
    ROW("fov_nan", "[camera]\nfov = nan\n", SYN, 2, 7, "t.cfg:2:7: fov: expected a finite number, got 'nan'"),
    ROW("eye_NaN", "[camera]\neye = 0 NaN 0\n", SYN, 2, 9, "t.cfg:2:9: eye: expected a finite number, got 'NaN'"),
    ROW("background_minus_nan", "[render]\nbackground = 0 0 -nan\n", SYN, 2, 18,
        "t.cfg:2:18: background: expected a finite number, got '-nan'"),
    ROW("nan_payload", "[render]\nbackground = nan(1) 0 0\n", SYN, 2, 14,
        "t.cfg:2:14: background: expected a finite number, got 'nan(1)'"),
    ROW("radius_inf", "[sphere]\nradius = inf\n", SYN, 2, 10,
        "t.cfg:2:10: radius: expected a finite number, got 'inf'"),
    ROW("color_minus_Infinity", "[light]\nposition = 0 0 0\ncolor = -Infinity 1 1\n", SYN, 3, 9,
        "t.cfg:3:9: color: expected a finite number, got '-Infinity'"),
    ROW("kd_plus_INF", "[material m]\ntype = diffuse\nkd = 1 +INF 1\n", SYN, 3, 8,
        "t.cfg:3:8: kd: expected a finite number, got '+INF'"),
    ROW("gamma_1e309", "[render]\ngamma = 1e309\n", SYN, 2, 9,
        "t.cfg:2:9: gamma: expected a finite number, got '1e309'"),
    ROW("target_minus_1e309", "[camera]\ntarget = 0 -1e309 0\n", SYN, 2, 12,
        "t.cfg:2:12: target: expected a finite number, got '-1e309'"),
    ROW("v0_INFINITY", "[triangle]\nv0 = INFINITY 0 0\n", SYN, 2, 6,
        "t.cfg:2:6: v0: expected a finite number, got 'INFINITY'"),
    ROW("uv1_1e400", "[triangle]\nuv1 = 0 1e400\n", SYN, 2, 9, "t.cfg:2:9: uv1: expected a finite number, got '1e400'"),
    ROW("width_inf", "[render]\nwidth = inf\n", SYN, 2, 9,
        "t.cfg:2:9: width: expected an integer in 1..16384, got 'inf'"),

    /* ---- unknown material ---- */
    ROW("spec_floor_undefined", SPEC_1_2 SPEC_3 SPEC_4_19 SPEC_20 SPEC_21_31, INV, 31, 12,
        "t.cfg:31:12: no material named 'floor'"),
    ROW("flor_no_close_name", "[material red]\ntype = diffuse\n[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = flor\n",
        INV, 6, 12, "t.cfg:6:12: no material named 'flor'"),
    /* The suggestion comes from a material defined after the use. */
    ROW("flor_floor_later", "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = flor\n[material floor]\ntype = diffuse\n",
        INV, 4, 12, "t.cfg:4:12: no material named 'flor'; did you mean 'floor'?"),
    /* Names are per kind: a light called red is no material. */
    ROW("light_name_is_not_material",
        "[light red]\nposition = 0 0 0\n[triangle]\nv0 = 0 0 0\nv1 = 1 0 0\nv2 = 0 1 0\nmaterial = red\n", INV, 7, 12,
        "t.cfg:7:12: no material named 'red'"),
    ROW("material_case", "[material red]\ntype = diffuse\n[plane]\npoint = 0 0 0\nnormal = 0 1 0\nmaterial = Red\n",
        INV, 6, 12, "t.cfg:6:12: no material named 'Red'; did you mean 'red'?"),
    ROW("material_quoted_space",
        "[material dark_red]\ntype = diffuse\n[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = \"dark red\"\n", INV, 6,
        12, "t.cfg:6:12: no material named 'dark red'; did you mean 'dark_red'?"),

    /* ---- missing required key (reported at the section header) ---- */
    ROW("sphere_no_radius", "[sphere]\ncenter = 0 0 0\nmaterial = m\n", INV, 1, 1,
        "t.cfg:1:1: [sphere] is missing required key 'radius'"),
    ROW("sphere_no_center_indented", "[render]\n\n  [sphere]\nradius = 2\nmaterial = m\n", INV, 3, 3,
        "t.cfg:3:3: [sphere] is missing required key 'center'"),
    ROW("sphere_no_material", "[sphere]\ncenter = 0 0 0\nradius = 1\n", INV, 1, 1,
        "t.cfg:1:1: [sphere] is missing required key 'material'"),
    ROW("plane_no_normal", "[plane p]\npoint = 0 0 0\nmaterial = m\n", INV, 1, 1,
        "t.cfg:1:1: [plane p] is missing required key 'normal'"),
    ROW("triangle_no_v2", "[triangle]\nv0 = 0 0 0\nv1 = 1 0 0\nmaterial = m\n", INV, 1, 1,
        "t.cfg:1:1: [triangle] is missing required key 'v2'"),
    ROW("point_no_position", "[light key]\ncolor = 1 1 1\n", INV, 1, 1,
        "t.cfg:1:1: [light key] is missing required key 'position'"),
    ROW("directional_no_direction", "[light sun]\ntype = directional\n", INV, 1, 1,
        "t.cfg:1:1: [light sun] is missing required key 'direction'"),
    ROW("spot_no_direction", "[light s]\ntype = spot\nposition = 0 1 0\n", INV, 1, 1,
        "t.cfg:1:1: [light s] is missing required key 'direction'"),
    ROW("area_no_edge2", "[light panel]\ntype = area\ncorner = 0 0 0\nedge1 = 1 0 0\n", INV, 1, 1,
        "t.cfg:1:1: [light panel] is missing required key 'edge2'"),
    ROW("material_no_type", "[material red]\nkd = 1 0 0\n", INV, 1, 1,
        "t.cfg:1:1: [material red] is missing required key 'type'"),
    ROW("textured_no_texture", "[material wood]\ntype = textured_phong\nks = 0.1 0.1 0.1\n", INV, 1, 1,
        "t.cfg:1:1: [material wood] is missing required key 'texture'"),
    ROW("mesh_no_file", "[mesh]\nmaterial = m\n", INV, 1, 1, "t.cfg:1:1: [mesh] is missing required key 'file'"),

    /* ---- degenerate geometry ---- */
    ROW("radius_0", "[sphere]\ncenter = 0 0 0\nradius = 0\nmaterial = m\n", INV, 3, 10,
        "t.cfg:3:10: radius: expected a number > 0, got '0'"),
    ROW("radius_negative", "[sphere]\ncenter = 0 0 0\nradius = -1\nmaterial = m\n", INV, 3, 10,
        "t.cfg:3:10: radius: expected a number > 0, got '-1'"),
    ROW("radius_minus_0", "[sphere]\ncenter = 0 0 0\nradius = -0\nmaterial = m\n", INV, 3, 10,
        "t.cfg:3:10: radius: expected a number > 0, got '-0'"),
    ROW("plane_normal_0", "[plane]\npoint = 0 0 0\nnormal = 0 0 0\nmaterial = m\n", INV, 3, 10,
        "t.cfg:3:10: normal: must not be the zero vector"),
    ROW("plane_normal_minus_0", "[plane]\npoint = 0 0 0\nnormal = 0 -0 0e5\nmaterial = m\n", INV, 3, 10,
        "t.cfg:3:10: normal: must not be the zero vector"),
    ROW("eye_is_target", "[camera]\neye = 1 2 3\ntarget = 1 2 3\n", INV, 3, 10,
        "t.cfg:3:10: camera: target must differ from eye"),
    /* target left at its default: no target line to point at. */
    ROW("eye_is_default_target", "[camera]\neye = 0 0 0\n", INV, 1, 1,
        "t.cfg:1:1: camera: target must differ from eye"),
    ROW("up_parallel", "[camera]\neye = 0 5 0\ntarget = 0 0 0\nup = 0 1 0\n", INV, 4, 6,
        "t.cfg:4:6: camera: up must not be parallel to target - eye"),
    ROW("up_antiparallel", "[camera]\neye = 0 0 5\nup = 0 0 -2\n", INV, 3, 6,
        "t.cfg:3:6: camera: up must not be parallel to target - eye"),
    ROW("up_default_parallel", "[camera]\neye = 0 5 0\n", INV, 1, 1,
        "t.cfg:1:1: camera: up must not be parallel to target - eye"),
    ROW("up_zero", "[camera]\nup = 0 0 0\n", INV, 2, 6, "t.cfg:2:6: camera: up must not be the zero vector"),
    ROW("directional_zero", "[light sun]\ntype = directional\ndirection = 0 0 0\n", INV, 3, 13,
        "t.cfg:3:13: direction: must not be the zero vector"),
    ROW("spot_zero", "[light s]\ntype = spot\nposition = 0 1 0\ndirection = 0 0 0\n", INV, 4, 13,
        "t.cfg:4:13: direction: must not be the zero vector"),
    ROW("triangle_zero_normal",
        "[triangle]\nv0 = 0 0 0\nv1 = 1 0 0\nv2 = 0 1 0\nn0 = 0 0 1\nn1 = 0 0 0\nn2 = 0 0 1\nmaterial = m\n", INV, 6, 6,
        "t.cfg:6:6: n1: must not be the zero vector"),
    ROW("triangle_some_normals", "[triangle]\nv0 = 0 0 0\nv1 = 1 0 0\nv2 = 0 1 0\nn0 = 0 0 1\nmaterial = m\n", SYN, 1,
        1, "t.cfg:1:1: [triangle] needs all of n0, n1, n2 or none of them"),
    ROW("triangle_some_uvs", "[triangle]\nv0 = 0 0 0\nv1 = 1 0 0\nv2 = 0 1 0\nuv0 = 0 0\nuv2 = 1 1\nmaterial = m\n",
        SYN, 1, 1, "t.cfg:1:1: [triangle] needs all of uv0, uv1, uv2 or none of them"),

    /* ---- invalid UTF-8 and NUL bytes ---- */
    ROW("utf8_ff", "[render]\nwidth = \xff\n", SYN, 2, 9, "t.cfg:2:9: invalid UTF-8"),
    /* Line 1, so the BOM variants check that the BOM is not a column. */
    ROW("utf8_truncated_line1", "[material r\xc3\xa9\xc3]\n", SYN, 1, 13, "t.cfg:1:13: invalid UTF-8"),
    ROW("utf8_overlong_line1", "# \xc0\xaf\n", SYN, 1, 3, "t.cfg:1:3: invalid UTF-8"),
    ROW("utf8_surrogate", "[render]\n# \xed\xa0\x80\n", SYN, 2, 3, "t.cfg:2:3: invalid UTF-8"),
    ROW("utf8_above_10ffff", "[render]\n# \xf4\x90\x80\x80\n", SYN, 2, 3, "t.cfg:2:3: invalid UTF-8"),
    ROW("utf8_lone_continuation", "[render]\n\n  \x80\n", SYN, 3, 3, "t.cfg:3:3: invalid UTF-8"),
    ROW("utf8_after_multibyte", "[render]\n# ééé \xfe\n", SYN, 2, 7, "t.cfg:2:7: invalid UTF-8"),
    ROW("utf8_cut_at_end", "[render]\nwidth = 1 # \xe2\x82", SYN, 2, 13, "t.cfg:2:13: invalid UTF-8"),
    ROW("nul_in_value",
        "[render]\nwidth = 6\0"
        "40\n",
        SYN, 2, 10, "t.cfg:2:10: NUL byte in the scene text"),
    ROW("nul_first_byte", "\0[render]\n", SYN, 1, 1, "t.cfg:1:1: NUL byte in the scene text"),

    /* ---- size limits ---- */
    ROWL("limit_bytes", "[render]\nwidth = 640\nheight = 480\n", LIM, 0, 0,
         "t.cfg: scene is %zu bytes, over the limit of 20 (--limit-scene-bytes)", max_bytes, 20, F_BYTES),
    ROWL("limit_objects",
         "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = m\n[plane]\npoint = 0 0 0\nnormal = 0 1 0\nmaterial = m\n"
         "[triangle]\nv0 = 0 0 0\nv1 = 1 0 0\nv2 = 0 1 0\nmaterial = m\n",
         LIM, 9, 1, "t.cfg:9:1: too many objects (limit 2, --limit-objects)", max_objects, 2, 0),
    ROWL("limit_lights", "[light a]\nposition = 0 0 0\n[light b]\nposition = 0 0 0\n", LIM, 3, 1,
         "t.cfg:3:1: too many lights (limit 1, --limit-lights)", max_lights, 1, 0),
    ROWL("limit_materials", "[material a]\ntype = diffuse\n[material b]\ntype = diffuse\n", LIM, 3, 1,
         "t.cfg:3:1: too many materials (limit 1, --limit-materials)", max_materials, 1, 0),
    ROWL("limit_material_name", "[material abcde]\ntype = diffuse\n", LIM, 1, 1,
         "t.cfg:1:1: material name is longer than the limit of 4 bytes (--limit-name-bytes)", max_name, 4, 0),
    ROWL("limit_light_name", "[light lamp1]\nposition = 0 0 0\n", LIM, 1, 1,
         "t.cfg:1:1: light name is longer than the limit of 4 bytes (--limit-name-bytes)", max_name, 4, 0),
    /* Three characters but six bytes: the limit is in bytes. */
    ROWL("limit_name_bytes", "[material ééé]\ntype = diffuse\n", LIM, 1, 1,
         "t.cfg:1:1: material name is longer than the limit of 4 bytes (--limit-name-bytes)", max_name, 4, 0),
    ROWL("limit_material_reference", "[sphere]\nmaterial = abcde\n", LIM, 2, 12,
         "t.cfg:2:12: material: longer than the limit of 4 bytes (--limit-name-bytes)", max_name, 4, 0),
    ROWL("limit_texture", "[material t]\ntype = textured_phong\ntexture = \"long.png\"\n", LIM, 3, 11,
         "t.cfg:3:11: texture: longer than the limit of 4 bytes (--limit-name-bytes)", max_name, 4, 0),
};

#define NROWS (sizeof rows / sizeof rows[0])

/* The parameter is a row index, not the row: Criterion copies parameters
 * into a freshly started test process, where pointers into this one's
 * string literals would dangle. */
ParameterizedTestParameters(cfg_errors, table)
{
    static size_t index[NROWS];
    for (size_t i = 0; i < NROWS; i++)
        index[i] = i;
    return cr_make_param_array(size_t, index, NROWS);
}

/* An independent UTF-8 check, so that the reader's own validator is not
 * what judges its messages. */
static int valid_utf8(const char *s)
{
    const unsigned char *p = (const unsigned char *)s;
    while (*p) {
        unsigned c = *p;
        int n = c < 0x80 ? 0 : (c & 0xe0) == 0xc0 ? 1 : (c & 0xf0) == 0xe0 ? 2 : (c & 0xf8) == 0xf0 ? 3 : -1;
        if (n < 0 || (n == 1 && c < 0xc2) || c > 0xf4)
            return 0;
        for (int k = 1; k <= n; k++)
            if ((p[k] & 0xc0) != 0x80)
                return 0;
        p += n + 1;
    }
    return 1;
}

static const char *const variant_names[] = {"LF", "CRLF", "BOM", "BOM+CRLF"};

/* The text of a row in one of the spellings the spec treats alike. The
 * buffer is exactly len bytes with no terminator, so ASan catches a read
 * past the end. */
static char *spell(const struct row *r, int variant, size_t *len)
{
    int crlf = variant & 1, bom = variant & 2;
    size_t n = bom ? 3 : 0;
    for (size_t i = 0; i < r->len; i++)
        n += (crlf && r->text[i] == '\n') ? 2 : 1;
    char *buf = malloc(n ? n : 1);
    cr_assert_not_null(buf);
    size_t j = 0;
    if (bom) {
        memcpy(buf, "\xef\xbb\xbf", 3);
        j = 3;
    }
    for (size_t i = 0; i < r->len; i++) {
        if (crlf && r->text[i] == '\n')
            buf[j++] = '\r';
        buf[j++] = r->text[i];
    }
    *len = n;
    return buf;
}

static int scene_is_zero(const rd_scene *s)
{
    static const rd_scene zero;
    return memcmp(s, &zero, sizeof zero) == 0;
}

/* A timeout turns a parser that loops forever into a failing row. */
ParameterizedTest(size_t *ip, cfg_errors, table, .timeout = 20)
{
    cr_assert_lt(*ip, NROWS);
    const struct row *r = &rows[*ip];
    for (int v = 0; v < 4; v++) {
        size_t len;
        char *text = spell(r, v, &len);
        char want[512];
        if (r->flags & F_BYTES) {
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
            snprintf(want, sizeof want, r->message, len);
#pragma GCC diagnostic pop
        } else {
            snprintf(want, sizeof want, "%s", r->message);
        }

        rd_scene s;
        rd_scene_init(&s);
        rd_error err;
        memset(&err, 0, sizeof err);
        err.line = err.column = -1;
        rd_scene_limits lim = rd_scene_limits_default();
        if (r->lim_value)
            *(size_t *)((char *)&lim + r->lim_field) = r->lim_value;
        rd_error_code rc = rd_cfg_parse(text, len, "t.cfg", &lim, &s, &err);

        cr_expect_eq(rc, r->code, "[%s %s] code %d, expected %d (message: %s)", r->name, variant_names[v], rc, r->code,
                     err.message);
        cr_expect_eq(err.code, rc, "[%s %s] err.code %d but returned %d", r->name, variant_names[v], err.code, rc);
        cr_expect_eq(err.line, r->line, "[%s %s] line %d, expected %d (message: %s)", r->name, variant_names[v],
                     err.line, r->line, err.message);
        cr_expect_eq(err.column, r->column, "[%s %s] column %d, expected %d (message: %s)", r->name, variant_names[v],
                     err.column, r->column, err.message);
        cr_expect(strcmp(err.message, want) == 0, "[%s %s] message\n  got:      %s\n  expected: %s", r->name,
                  variant_names[v], err.message, want);
        cr_expect(valid_utf8(err.message), "[%s %s] message is not valid UTF-8: %s", r->name, variant_names[v],
                  err.message);

        rd_scene_free(&s);
        cr_expect(scene_is_zero(&s), "[%s %s] rd_scene_free left fields behind", r->name, variant_names[v]);
        free(text);
    }
}

/* ---- errors outside the table ---- */

static rd_error_code parse_text(const char *text, const rd_scene_limits *lim, rd_error *err)
{
    rd_scene s;
    rd_scene_init(&s);
    memset(err, 0, sizeof *err);
    rd_error_code rc = rd_cfg_parse(text, strlen(text), "t.cfg", lim, &s, err);
    rd_scene_free(&s);
    return rc;
}

static char *repeat(const char *head, const char *unit, int times, const char *tail)
{
    size_t n = strlen(head) + strlen(unit) * (size_t)times + strlen(tail) + 1;
    char *s = malloc(n);
    cr_assert_not_null(s);
    strcpy(s, head);
    for (int i = 0; i < times; i++)
        strcat(s, unit);
    strcat(s, tail);
    return s;
}

/* Messages reach HTTP clients inside JSON: cutting a long name or token to
 * a fixed number of bytes must not split a multi-byte character. Each input
 * puts an odd number of ASCII bytes before two-byte characters so that a
 * byte cut lands inside one. */
Test(cfg_errors, messages_stay_valid_utf8_when_cut)
{
    struct {
        const char *what;
        char *text;
        rd_error_code code;
        const char *prefix;
    } cases[] = {
        {"long token", repeat("[render]\nwidth = a", "é", 45, "\n"), RD_ERR_SYNTAX, "t.cfg:2:9: width: "},
        {"long section name", repeat("[material x", "é", 40, "]\ntype = diffuse\nfoo = 1\n"), RD_ERR_SYNTAX,
         "t.cfg:3:1: unknown key 'foo' in [material x"},
        {"long material reference", repeat("[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = x", "é", 40, "\n"),
         RD_ERR_INVALID, "t.cfg:4:12: no material named 'x"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rd_error err;
        rd_error_code rc = parse_text(cases[i].text, NULL, &err);
        cr_expect_eq(rc, cases[i].code, "%s: code %d (%s)", cases[i].what, rc, err.message);
        cr_expect(strncmp(err.message, cases[i].prefix, strlen(cases[i].prefix)) == 0,
                  "%s: message %s, expected to start with %s", cases[i].what, err.message, cases[i].prefix);
        cr_expect(valid_utf8(err.message), "%s: message is not valid UTF-8: %s", cases[i].what, err.message);
        free(cases[i].text);
    }
}

/* up = 0 1 0 is perpendicular to a view along z however long or short the
 * view (or up) is: overflow in target - eye, or a subnormal vector, must
 * not be blamed on up being parallel. Accepting the camera or refusing it
 * with a message that names the real problem both pass. */
Test(cfg_errors, camera_parallel_check_not_fooled_by_magnitude)
{
    static const char *const texts[] = {
        "[camera]\neye = 0 0 1e308\ntarget = 0 0 -1e308\nup = 0 1 0\n",
        "[camera]\neye = 0 0 1e-310\ntarget = 0 0 0\nup = 0 1 0\n",
        "[camera]\neye = 0 0 1\ntarget = 0 0 0\nup = 0 1e-310 0\n",
    };
    for (size_t i = 0; i < sizeof texts / sizeof texts[0]; i++) {
        rd_error err;
        rd_error_code rc = parse_text(texts[i], NULL, &err);
        cr_expect(rc == RD_OK || strstr(err.message, "parallel") == NULL,
                  "up is perpendicular to the view, yet for\n%s  -> %s", texts[i], err.message);
    }
}

/* Callers that only want the code pass no rd_error. */
Test(cfg_errors, null_error_pointer)
{
    rd_scene s;
    rd_scene_init(&s);
    const char *text = "[render]\nwidth = 0\n";
    cr_expect_eq(rd_cfg_parse(text, strlen(text), "t.cfg", NULL, &s, NULL), RD_ERR_SYNTAX);
    rd_scene_free(&s);
    rd_scene_init(&s);
    text = "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = nope\n";
    cr_expect_eq(rd_cfg_parse(text, strlen(text), NULL, NULL, &s, NULL), RD_ERR_INVALID);
    rd_scene_free(&s);
}

/* Limits are maxima, not bounds to stay under. */
Test(cfg_errors, limits_are_inclusive)
{
    const char *text = "[material abcd]\ntype = diffuse\n[light l]\nposition = 0 0 0\n"
                       "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = abcd\n";
    rd_scene_limits lim = rd_scene_limits_default();
    lim.max_bytes = strlen(text);
    lim.max_objects = lim.max_lights = lim.max_materials = 1;
    lim.max_name = 4;
    rd_error err;
    rd_error_code rc = parse_text(text, &lim, &err);
    cr_expect_eq(rc, RD_OK, "%s", err.message);
}

/* A file is refused by its size before it is read. */
Test(cfg_errors, load_file_over_byte_limit)
{
    struct stat st;
    cr_assert_eq(stat("scenes/phong.cfg", &st), 0, "run from the repository root");
    rd_scene_limits lim = rd_scene_limits_default();
    lim.max_bytes = 100;
    rd_scene s;
    rd_scene_init(&s);
    rd_error err;
    memset(&err, 0, sizeof err);
    rd_error_code rc = rd_scene_load_file("scenes/phong.cfg", &lim, &s, &err);
    char want[200];
    snprintf(want, sizeof want, "scenes/phong.cfg: %lld bytes, over the limit of 100 (--limit-scene-bytes)",
             (long long)st.st_size);
    cr_expect_eq(rc, RD_ERR_LIMIT);
    cr_expect_str_eq(err.message, want);
    rd_scene_free(&s);
}

Test(cfg_errors, load_file_directory)
{
    rd_scene s;
    rd_scene_init(&s);
    rd_error err;
    memset(&err, 0, sizeof err);
    rd_error_code rc = rd_scene_load_file("scenes", NULL, &s, &err);
    cr_expect_eq(rc, RD_ERR_IO, "%s", err.message);
    cr_expect_str_eq(err.message, "scenes: not a regular file");
    rd_scene_free(&s);
}

/* Whatever damage a text has, the answer is RD_OK or one error that points
 * at a real place in it. Every prefix of the spec's example, and the example
 * with each byte replaced by a troublesome one, is parsed from an exact-size
 * buffer (ASan sees over-reads). */
static void check_any(const char *text, size_t len, const char *what, size_t at)
{
    char *buf = malloc(len ? len : 1);
    cr_assert_not_null(buf);
    memcpy(buf, text, len);
    int lines = 1;
    for (size_t i = 0; i < len; i++)
        lines += buf[i] == '\n';
    rd_scene s;
    rd_scene_init(&s);
    rd_error err;
    memset(&err, 0, sizeof err);
    rd_error_code rc = rd_cfg_parse(buf, len, "t.cfg", NULL, &s, &err);
    if (rc != RD_OK) {
        char prefix[64];
        snprintf(prefix, sizeof prefix, "t.cfg:%d:%d: ", err.line, err.column);
        cr_expect(err.line >= 1 && err.line <= lines && err.column >= 1, "%s %zu: line %d column %d: %s", what, at,
                  err.line, err.column, err.message);
        cr_expect(strncmp(err.message, prefix, strlen(prefix)) == 0, "%s %zu: %s", what, at, err.message);
        cr_expect(valid_utf8(err.message), "%s %zu: not UTF-8: %s", what, at, err.message);
    }
    rd_scene_free(&s);
    free(buf);
}

Test(cfg_errors, damaged_spec_example_never_crashes, .timeout = 120)
{
    static const char spec[] = SPEC_1_2 SPEC_3 SPEC_4_19 SPEC_20 SPEC_21_31 "\n[material floor]\ntype = diffuse\n";
    size_t n = sizeof spec - 1;
    for (size_t i = 0; i <= n; i++)
        check_any(spec, i, "prefix", i);
    static const char bad[] = {'[', ']', '"', '=', '#', ';', ' ', '\n', '\r', '\0', '\xff', '\xc3', 'x', '-'};
    char *copy = malloc(n);
    cr_assert_not_null(copy);
    for (size_t i = 0; i < n; i++) {
        for (size_t k = 0; k < sizeof bad; k++) {
            memcpy(copy, spec, n);
            copy[i] = bad[k];
            check_any(copy, n, "byte", i);
        }
    }
    free(copy);
}
