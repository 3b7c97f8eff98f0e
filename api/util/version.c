#include "version.h"

#ifndef RD_VERSION
#define RD_VERSION "unknown"
#endif

const char *rd_version(void) { return RD_VERSION; }
