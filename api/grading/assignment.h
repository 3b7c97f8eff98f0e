/* Graded assignments: a folder (one per course) of NAME.cfg scenes, each
 * with an optional NAME.grade file of thresholds and a title:
 *
 *     title = Phong: three spheres of rising shininess
 *     fail = 3
 *     fail_fraction = 0.001
 *     hard_fail = 48
 *     hard_fail_pixels = 16
 *     shininess = natural
 *
 * and the term's keys (term.h: release, due, late_days, late_penalty,
 * points, credit, image_credit, counts).
 * Keys left out keep the calibrated defaults (rd_grade_thresholds_default).
 * shininess is the domain the assignment's text gives the Phong exponent n
 * (the course's handout: a natural number); a student's code is called on
 * configurations inside it only (code_cases.h), since code that is right
 * for every n the text allows must pass. */
#ifndef RD_ASSIGNMENT_H
#define RD_ASSIGNMENT_H

#include <stddef.h>

#include "grade.h"
#include "rayd/error.h"
#include "term.h"

/* The shininess an assignment allows: any positive number, or only the
 * natural numbers 1, 2, 3... */
typedef enum { RD_SHININESS_REAL, RD_SHININESS_NATURAL } rd_shininess_domain;

typedef struct {
    char name[64];
    char title[160];
    char scene_path[512];
    rd_grade_thresholds thresholds;
    rd_shininess_domain shininess;
    rd_term term; /* term.h: the schedule, points, credit and which grade counts */
    /* rd_assignment_list only: why it cannot be graded ("phong.grade:3:1:
     * ..."), naming files by their names in the folder, never by path;
     * "" when it can. */
    char error[512];
} rd_assignment;

/* Loads assignment `name` (letters, digits, '_' and '-') from dir.
 * RD_ERR_NOT_FOUND when there is no such assignment (the name is not one,
 * or its .cfg is missing or links out of dir); RD_ERR_SYNTAX for a bad
 * .grade file (with line and column); RD_ERR_IO when it cannot be read. */
rd_error_code rd_assignment_load(const char *dir, const char *name, rd_assignment *a, rd_error *err);

/* Every assignment in dir, sorted by name; *list is malloc'ed. One that
 * does not load is listed with its error, so that a broken .grade file
 * hides nothing but itself. Fails only when dir cannot be read (RD_ERR_IO)
 * or on RD_ERR_NOMEM. */
rd_error_code rd_assignment_list(const char *dir, rd_assignment **list, size_t *n, rd_error *err);

#endif
