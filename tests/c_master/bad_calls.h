/* The bad-input list of docs/robustness.md, run against a loaded FMU (see bad_calls.c). */
#ifndef AEM_C_MASTER_BAD_CALLS_H
#define AEM_C_MASTER_BAD_CALLS_H

#include "fmu.h"

/* Prints the table rows to stdout; returns 0, or 1 if a bad call was accepted. */
int run_bad_calls(const Fmu *fmu, LogSink *sink);

#endif
