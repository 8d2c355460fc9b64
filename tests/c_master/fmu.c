/* See fmu.h. The platform's loader: LoadLibrary/GetProcAddress on Windows (built with
 * mingw-w64), dlopen/dlsym elsewhere (POSIX; realpath, which glibc declares for X/Open). */
#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#define FMI2_PLATFORM "win64"
#define LIBRARY_SUFFIX ".dll"
#else
#define _XOPEN_SOURCE 700
#include <dlfcn.h>
#define FMI2_PLATFORM "linux64"
#define LIBRARY_SUFFIX ".so"
#endif

#include "fmu.h"

#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char *read_file(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        perror(path);
        return NULL;
    }
    size_t cap = 1 << 14, len = 0;
    char *text = malloc(cap);
    while (text) {
        len += fread(text + len, 1, cap - 1 - len, f);
        if (len < cap - 1) break;
        char *bigger = realloc(text, cap *= 2);
        if (!bigger) free(text);
        text = bigger;
    }
    int failed = ferror(f);
    fclose(f);
    if (!text || failed) {
        fprintf(stderr, "cannot read %s\n", path);
        free(text);
        return NULL;
    }
    text[len] = '\0';
    return text;
}

/* The value of attribute `name` (e.g. ` guid`) at or after `from` and before the end of
 * the element's start tag; a fresh string, or NULL. A simple scan, not an XML parser: it
 * is enough for the attributes of this model description, which hold no '>' or quotes. */
static char *attribute(const char *from, const char *name) {
    const char *tag_end = strchr(from, '>');
    char pattern[64];
    snprintf(pattern, sizeof pattern, "%s=\"", name);
    const char *at = strstr(from, pattern);
    if (!at || !tag_end || at > tag_end) return NULL;
    at += strlen(pattern);
    const char *end = strchr(at, '"');
    if (!end) return NULL;
    char *value = malloc((size_t)(end - at) + 1);
    if (value) {
        memcpy(value, at, (size_t)(end - at));
        value[end - at] = '\0';
    }
    return value;
}

/* The value of `name` in the start tag of the first element `<element`. */
static char *element_attribute(const char *xml, const char *element, const char *name) {
    const char *at = strstr(xml, element);
    return at ? attribute(at, name) : NULL;
}

fmi2ValueReference fmu_value_reference(const Fmu *fmu, const char *name) {
    char pattern[128];
    snprintf(pattern, sizeof pattern, " name=\"%s\"", name);
    const char *at = strstr(fmu->model_description, pattern);
    /* The start tag of the ScalarVariable holding this name attribute. */
    while (at && at > fmu->model_description && *at != '<') at--;
    char *text = at ? attribute(at, " valueReference") : NULL;
    if (!text) {
        fprintf(stderr, "modelDescription.xml has no ScalarVariable %s with a valueReference\n", name);
        exit(1);
    }
    char *end;
    unsigned long vr = strtoul(text, &end, 10);
    if (*end != '\0' || end == text || vr > UINT_MAX) {
        fprintf(stderr, "valueReference \"%s\" of %s is not an unsigned int\n", text, name);
        exit(1);
    }
    free(text);
    return (fmi2ValueReference)vr;
}

static char *join(const char *a, const char *b, const char *c) {
    size_t n = strlen(a) + strlen(b) + strlen(c) + 1;
    char *s = malloc(n);
    if (s) snprintf(s, n, "%s%s%s", a, b, c);
    return s;
}

/* The absolute path of `dir` with '/' as separator ("C:/x/y" on Windows); NULL on error. */
static char *absolute_path(const char *dir) {
#ifdef _WIN32
    char *path = _fullpath(NULL, dir, 0);
    for (char *p = path; p && *p; p++)
        if (*p == '\\') *p = '/';
#else
    char *path = realpath(dir, NULL);
#endif
    if (!path) perror(dir);
    return path;
}

/* The file URI of an absolute path (RFC 8089): file:///home/x or file:///C:/x, every byte
 * outside RFC 3986's unreserved characters, '/' and ':' percent-encoded ("a b" -> "a%20b"). */
char *fmu_file_uri(const char *absolute) {
    const char *prefix = absolute[0] == '/' ? "file://" : "file:///";
    char *uri = malloc(strlen(prefix) + 3 * strlen(absolute) + 1);
    if (!uri) return NULL;
    char *out = uri + sprintf(uri, "%s", prefix);
    for (const unsigned char *p = (const unsigned char *)absolute; *p; p++) {
        if ((*p >= 'A' && *p <= 'Z') || (*p >= 'a' && *p <= 'z') || (*p >= '0' && *p <= '9') ||
            strchr("-._~/:", *p))
            *out++ = (char)*p;
        else
            out += sprintf(out, "%%%02X", *p);
    }
    *out = '\0';
    return uri;
}

/* The platform's loader, behind three calls (fmu.h). */
void *fmu_library_open(const char *path) {
#ifdef _WIN32
    /* The DLL's own folder is searched for the libraries it imports (FMI 2.0, section 2.3). */
    HMODULE library = LoadLibraryExA(path, NULL, LOAD_WITH_ALTERED_SEARCH_PATH);
    if (!library) fprintf(stderr, "LoadLibrary %s: error %lu\n", path, (unsigned long)GetLastError());
    return (void *)library;
#else
    void *library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!library) fprintf(stderr, "dlopen: %s\n", dlerror());
    return library;
#endif
}

/* The address of `name`, as a data pointer: ISO C has no conversion from it to a function
 * pointer, so the caller copies the bytes (POSIX and Windows guarantee the same size). */
void *fmu_library_symbol(void *library, const char *name) {
#ifdef _WIN32
    FARPROC symbol = GetProcAddress((HMODULE)library, name);
    void *address;
    memcpy(&address, &symbol, sizeof address);
    return address;
#else
    return dlsym(library, name);
#endif
}

int fmu_library_close(void *library) {
#ifdef _WIN32
    if (FreeLibrary((HMODULE)library)) return 0;
    fprintf(stderr, "FreeLibrary: error %lu\n", (unsigned long)GetLastError());
#else
    if (dlclose(library) == 0) return 0;
    fprintf(stderr, "dlclose: %s\n", dlerror());
#endif
    return -1;
}

int fmu_load(Fmu *fmu, const char *dir) {
    memset(fmu, 0, sizeof *fmu);
    char *path = join(dir, "/", "modelDescription.xml");
    fmu->model_description = path ? read_file(path) : NULL;
    free(path);
    if (!fmu->model_description) return -1;

    const char *md = fmu->model_description;
    char *version = element_attribute(md, "<fmiModelDescription", " fmiVersion");
    int is_fmi2 = version && strcmp(version, fmi2Version) == 0;
    free(version);
    if (!is_fmi2) {
        fprintf(stderr, "%s: not an FMI %s model description\n", dir, fmi2Version);
        return -1;
    }
    fmu->guid = element_attribute(md, "<fmiModelDescription", " guid");
    fmu->model_identifier = element_attribute(md, "<CoSimulation", " modelIdentifier");
    if (!fmu->guid || !fmu->model_identifier) {
        fprintf(stderr, "%s: no guid or no <CoSimulation modelIdentifier>\n", dir);
        return -1;
    }

    /* FMI 2.0, section 2.1.5: fmuResourceLocation is a URI of the resources folder. */
    char *absolute = absolute_path(dir);
    if (!absolute) return -1;
    char *resources = join(absolute, "/resources", "");
    fmu->resource_uri = resources ? fmu_file_uri(resources) : NULL;
    free(resources);

    /* FMI 2.0, section 2.3: binaries/<platform>/<modelIdentifier>.<so|dll|dylib>. */
    char *binaries = join(absolute, "/binaries/" FMI2_PLATFORM "/", fmu->model_identifier);
    char *library = binaries ? join(binaries, LIBRARY_SUFFIX, "") : NULL;
    free(binaries);
    free(absolute);
    if (!fmu->resource_uri || !library) {
        free(library);
        return -1;
    }
    fmu->library = fmu_library_open(library);
    free(library);
    if (!fmu->library) return -1;

    int missing = 0;
#define FMI2_RESOLVE(name)                                                                 \
    {                                                                                      \
        void *symbol = fmu_library_symbol(fmu->library, "fmi2" #name);                     \
        if (!symbol) {                                                                     \
            fprintf(stderr, "the library does not export fmi2" #name "\n");                \
            missing++;                                                                     \
        }                                                                                  \
        memcpy(&fmu->name, &symbol, sizeof symbol);                                        \
    }
    FMI2_CS_FUNCTIONS(FMI2_RESOLVE)
#undef FMI2_RESOLVE
    return missing ? -1 : 0;
}

int fmu_unload(Fmu *fmu) {
    int rc = 0;
    if (fmu->library && fmu_library_close(fmu->library) != 0) rc = -1;
    free(fmu->guid);
    free(fmu->model_identifier);
    free(fmu->resource_uri);
    free(fmu->model_description);
    memset(fmu, 0, sizeof *fmu);
    return rc;
}

const char *fmu_status_name(fmi2Status status) {
    static const char *const names[] = {"fmi2OK", "fmi2Warning", "fmi2Discard", "fmi2Error",
                                        "fmi2Fatal", "fmi2Pending"};
    return (unsigned)status <= fmi2Pending ? names[status] : "(not an fmi2Status)";
}

void fmu_logger(fmi2ComponentEnvironment env, fmi2String instance_name, fmi2Status status,
                fmi2String category, fmi2String message, ...) {
    /* FMI 2.0, section 2.1.5: `message` is a printf format string for the arguments that
     * follow (it may also hold #<Type><valueReference># references, printed as they are). */
    va_list args, probe;
    va_start(args, message);
    va_copy(probe, args);
    int length = message ? vsnprintf(NULL, 0, message, probe) : -1;
    va_end(probe);
    char *text = length >= 0 ? malloc((size_t)length + 1) : NULL;
    if (text) vsnprintf(text, (size_t)length + 1, message, args);
    va_end(args);

    LogSink *sink = env;
    if (sink && (unsigned)status <= fmi2Pending) sink->count[status]++;
    if (sink && !sink->first[0] && text) snprintf(sink->first, sizeof sink->first, "%s", text);
    if (!sink || !sink->quiet) {
        fprintf(stderr, "[%s] %s (%s): %s\n", fmu_status_name(status),
                instance_name ? instance_name : "(null)", category ? category : "(null)",
                text ? text : "(message could not be formatted)");
    }
    free(text);
}
