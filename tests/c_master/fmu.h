/* Loading an extracted FMI 2.0 co-simulation FMU: its model description (the few facts a
 * master needs), its shared library (all 34 common and co-simulation functions) and a
 * logger callback.
 *
 * Compiled against the standard's own headers (fmi2Functions.h, fmi2FunctionTypes.h,
 * fmi2TypesPlatform.h), taken from the fmi-sys crate at build time, so every function
 * pointer has exactly the type the standard declares. */
#ifndef AEM_C_MASTER_FMU_H
#define AEM_C_MASTER_FMU_H

#include <stddef.h>

#include "fmi2Functions.h"

/* The 34 functions a co-simulation FMU must export (FMI 2.0, sections 2.1 and 4.2): the
 * common functions, the FMU-state and directional-derivative functions (exported even when
 * the capability flags say they are not provided) and the co-simulation functions. */
#define FMI2_CS_FUNCTIONS(X)                                                                   \
    X(GetTypesPlatform) X(GetVersion) X(SetDebugLogging)                                       \
    X(Instantiate) X(FreeInstance)                                                             \
    X(SetupExperiment) X(EnterInitializationMode) X(ExitInitializationMode)                    \
    X(Terminate) X(Reset)                                                                      \
    X(GetReal) X(GetInteger) X(GetBoolean) X(GetString)                                        \
    X(SetReal) X(SetInteger) X(SetBoolean) X(SetString)                                        \
    X(GetFMUstate) X(SetFMUstate) X(FreeFMUstate)                                              \
    X(SerializedFMUstateSize) X(SerializeFMUstate) X(DeSerializeFMUstate)                      \
    X(GetDirectionalDerivative)                                                                \
    X(SetRealInputDerivatives) X(GetRealOutputDerivatives)                                     \
    X(DoStep) X(CancelStep)                                                                    \
    X(GetStatus) X(GetRealStatus) X(GetIntegerStatus) X(GetBooleanStatus) X(GetStringStatus)

/* One loaded FMU: `fmu.DoStep` is the FMU's fmi2DoStep, typed by the standard's header. */
typedef struct {
    void *library; /* dlopen handle, or the HMODULE on Windows */
    char *guid;
    char *model_identifier;
    char *resource_uri; /* file:// URI of <dir>/resources */
    char *model_description; /* the file's text, for value_reference() */
#define FMI2_FIELD(name) fmi2##name##TYPE *name;
    FMI2_CS_FUNCTIONS(FMI2_FIELD)
#undef FMI2_FIELD
} Fmu;

/* Reads <dir>/modelDescription.xml and loads <dir>/binaries/linux64/<modelIdentifier>.so
 * (binaries/win64/<modelIdentifier>.dll on Windows), resolving every function. Returns 0, or
 * -1 after printing why to stderr. */
int fmu_load(Fmu *fmu, const char *dir);

/* The platform's loader (dlopen/dlsym/dlclose, or LoadLibrary/GetProcAddress/FreeLibrary):
 * a library by path (NULL after printing why), the address of one of its symbols as a data
 * pointer (NULL if absent; copy its bytes into a function pointer), and closing it (0 or -1). */
void *fmu_library_open(const char *path);
void *fmu_library_symbol(void *library, const char *name);
int fmu_library_close(void *library);

/* Unloads the library and frees what fmu_load allocated. Returns 0, or -1 if dlclose fails. */
int fmu_unload(Fmu *fmu);

/* The file URI of an absolute path with '/' separators, percent-encoded: a fresh string. */
char *fmu_file_uri(const char *absolute);

/* The valueReference of the ScalarVariable called `name`; exits if there is none. */
fmi2ValueReference fmu_value_reference(const Fmu *fmu, const char *name);

/* What the logger saw: messages counted per status, printed to stderr unless quiet; the
 * first message since `first` was last emptied is kept in it. */
typedef struct {
    unsigned long count[fmi2Pending + 1];
    int quiet;
    char first[1024];
} LogSink;

/* The fmi2CallbackLogger: formats the printf-style message with vsnprintf. Its
 * componentEnvironment must be a LogSink. */
void fmu_logger(fmi2ComponentEnvironment env, fmi2String instance_name, fmi2Status status,
                fmi2String category, fmi2String message, ...);

const char *fmu_status_name(fmi2Status status);

#endif
