/* The build's identity: `git describe` when it was built from a checkout,
 * the VERSION file of a release tarball otherwise (the Makefile decides). */
#ifndef RD_VERSION_H
#define RD_VERSION_H

/* A static string such as "0.1.0-12-g395d23a"; never NULL. */
const char *rd_version(void);

/* The data folder compiled in: the source tree for build/rayd,
 * $(PREFIX)/share/rayd for an installed rayd. The bundled scenes are in
 * its scenes/, the assignments in scenes/assignments/. Static strings. */
const char *rd_data_dir(void);
const char *rd_default_scenes_dir(void);
const char *rd_default_assignments_dir(void);

/* The code grader's files (docs/grading.md, "Grading code"): the course's
 * headers and adapter (the source tree's daemon/codegrade/course, or
 * $(PREFIX)/share/rayd/course), and the evaluator (build/rayd-eval, or
 * $(PREFIX)/libexec/rayd/rayd-eval). Static strings. */
const char *rd_default_course_dir(void);
const char *rd_default_eval_path(void);

/* Whether this is an installed rayd (make install) rather than build/rayd:
 * an installed one keeps its state in the user's or the service's state
 * folder, not in the folder it was started from. */
int rd_installed(void);

#endif
