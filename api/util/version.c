#include "version.h"

#ifndef RD_VERSION
#define RD_VERSION "unknown"
#endif
#ifndef RD_DATA_DIR
#define RD_DATA_DIR "."
#endif
#ifndef RD_COURSE_DIR
#define RD_COURSE_DIR RD_DATA_DIR "/course"
#endif
/* 1 in the binary make install builds (its data folder is the prefix's),
 * 0 in build/rayd, which runs from the source tree. */
#ifndef RD_INSTALLED
#define RD_INSTALLED 0
#endif
#ifndef RD_EVAL_PATH
#define RD_EVAL_PATH "rayd-eval"
#endif

const char *rd_version(void) { return RD_VERSION; }

const char *rd_data_dir(void) { return RD_DATA_DIR; }

const char *rd_default_scenes_dir(void) { return RD_DATA_DIR "/scenes"; }

const char *rd_default_assignments_dir(void) { return RD_DATA_DIR "/scenes/assignments"; }

const char *rd_default_course_dir(void) { return RD_COURSE_DIR; }

const char *rd_default_eval_path(void) { return RD_EVAL_PATH; }

int rd_installed(void) { return RD_INSTALLED; }
