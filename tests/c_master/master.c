/* A small FMI 2.0 co-simulation master in C11, the third independent importer of the FMU.
 *
 *   master --fmu-dir DIR --schedule CSV --step H --stop T --out CSV
 *          [--modules N --parameter-file PATH-OR-URI] [--resource-uri URI] [--drive LIBRARY]
 *       Runs a setpoint schedule (rows "time,setpoint": the setpoint holds from that time on;
 *       the first row's time is the start time) with fixed communication steps H up to T
 *       and writes time,current,voltage,power,h2Flow,energy,h2Produced after initialisation
 *       and after every step, each value with %.17g (it reads back to the same double).
 *       --modules and --parameter-file make it a hub of N modules with the given
 *       moduleParameterFile; --resource-uri replaces the fmuResourceLocation that the
 *       master derives from DIR (to try the forms a master may pass). --drive steps through
 *       the schedule with aem_drive_series of LIBRARY (the Python package's native stepping
 *       loop, crates/drive) instead of this master's own loop: the same rows, read after
 *       setting each point's setpoint instead of before (the outputs are states: no
 *       direct feedthrough), with steps t[k+1] - t[k].
 *
 *   master --fmu-dir DIR --bad-calls table
 *       Prints the bad-input table of docs/robustness.md as this library answers it (bad_calls.c).
 *
 *   master --fmu-dir DIR --cycles N [--inject leak|invalid-read]
 *       N instantiate/step/free cycles for a memory checker (see cycle()). --inject adds one
 *       deliberate leak or out-of-bounds read, so a test can show its checker catches them.
 *
 * DIR is the extracted .fmu. Every fmi2 call's status is checked; any unexpected status
 * ends the program with exit code 1. */
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bad_calls.h"
#include "fmu.h"

#define VARIABLE_NAMES(X) X(setpoint) X(current) X(voltage) X(power) X(h2Flow) X(energy) X(h2Produced)
#define N_OUTPUTS 6

static Fmu fmu;
static LogSink sink;
static fmi2ValueReference setpoint_vr, output_vrs[N_OUTPUTS];
/* The hub's Integer settings nModules, dispatch, belowMinimum, and its String moduleParameterFile. */
static fmi2ValueReference hub_vrs[3], file_vr;
/* fmuResourceLocation: the file URI of DIR/resources, or --resource-uri. */
static const char *resource_uri;

static void die(const char *what) {
    fprintf(stderr, "master: %s\n", what);
    exit(1);
}

/* Ends the program unless `status` is one of the allowed ones (a bit mask of statuses). */
#define ALLOW(s) (1u << (s))
static void check(fmi2Status status, unsigned allowed, const char *call) {
    if ((unsigned)status > fmi2Pending || !(allowed & ALLOW(status))) {
        fprintf(stderr, "master: %s returned %s\n", call, fmu_status_name(status));
        exit(1);
    }
}
#define OK(call) check((call), ALLOW(fmi2OK), #call)
/* setReal of the input, and exitInitializationMode, warn when the setpoint is outside the
 * module's operating window: the value is clamped, the call still succeeds. */
#define OK_OR_WARNING(call) check((call), ALLOW(fmi2OK) | ALLOW(fmi2Warning), #call)

/* The FMU must refuse the call with fmi2Error and say why through the logger. */
#define REFUSED(call)                                                                          \
    do {                                                                                       \
        unsigned long errors_before = sink.count[fmi2Error];                                   \
        check((call), ALLOW(fmi2Error), #call);                                                \
        if (sink.count[fmi2Error] == errors_before) die("no error message for: " #call);      \
    } while (0)

static void lookup_variables(void) {
    const char *names[] = {
#define NAME(v) #v,
        VARIABLE_NAMES(NAME)
#undef NAME
    };
    setpoint_vr = fmu_value_reference(&fmu, names[0]);
    for (int i = 0; i < N_OUTPUTS; i++) output_vrs[i] = fmu_value_reference(&fmu, names[i + 1]);
    hub_vrs[0] = fmu_value_reference(&fmu, "nModules");
    hub_vrs[1] = fmu_value_reference(&fmu, "dispatch");
    hub_vrs[2] = fmu_value_reference(&fmu, "belowMinimum");
    file_vr = fmu_value_reference(&fmu, "moduleParameterFile");
}

static fmi2Component instantiate(const char *name, const char *guid) {
    /* FMI 2.0, section 2.1.5: logger, allocateMemory and freeMemory must be given (this FMU
     * declares canNotUseMemoryManagementFunctions, yet a master provides them all the same);
     * stepFinished only matters for asynchronous steps. */
    static const fmi2CallbackFunctions callbacks = {
        .logger = fmu_logger,
        .allocateMemory = calloc,
        .freeMemory = free,
        .stepFinished = NULL,
        .componentEnvironment = &sink,
    };
    return fmu.Instantiate(name, fmi2CoSimulation, guid, resource_uri, &callbacks, fmi2False,
                           fmi2False);
}

static void set_setpoint(fmi2Component c, double value) {
    OK_OR_WARNING(fmu.SetReal(c, &setpoint_vr, 1, &value));
}

static void get_outputs(fmi2Component c, double values[N_OUTPUTS]) {
    OK(fmu.GetReal(c, output_vrs, N_OUTPUTS, values));
}

/* ------------------------------------------------------------------ schedule run */

typedef struct {
    double *time, *setpoint;
    size_t n;
} Schedule;

static Schedule read_schedule(const char *path) {
    FILE *f = fopen(path, "r");
    if (!f) die("cannot open the schedule");
    Schedule s = {0};
    size_t cap = 0;
    char line[256];
    if (!fgets(line, sizeof line, f) || strncmp(line, "time,setpoint", 13) != 0)
        die("the schedule must start with the header time,setpoint");
    while (fgets(line, sizeof line, f)) {
        char *end;
        double t = strtod(line, &end);
        if (end == line) continue; /* blank line */
        if (*end != ',') die("schedule rows are time,setpoint");
        char *field = end + 1;
        double u = strtod(field, &end);
        if (end == field || !isfinite(t) || !isfinite(u)) die("bad number in the schedule");
        if (s.n > 0 && !(t > s.time[s.n - 1])) die("schedule times must increase");
        if (s.n == cap) {
            cap = cap ? 2 * cap : 16;
            double *time = realloc(s.time, cap * sizeof *time);
            if (!time) die("out of memory");
            s.time = time;
            double *setpoint = realloc(s.setpoint, cap * sizeof *setpoint);
            if (!setpoint) die("out of memory");
            s.setpoint = setpoint;
        }
        s.time[s.n] = t;
        s.setpoint[s.n++] = u;
    }
    fclose(f);
    if (s.n == 0) die("the schedule is empty");
    return s;
}

/* The setpoint in force at time t: that of the last row with time <= t. */
static double setpoint_at(const Schedule *s, double t) {
    size_t i = 0;
    while (i + 1 < s->n && s->time[i + 1] <= t) i++;
    return s->setpoint[i];
}

static void write_row(FILE *out, double t, const double values[N_OUTPUTS]) {
    fprintf(out, "%.17g", t);
    for (int i = 0; i < N_OUTPUTS; i++) fprintf(out, ",%.17g", values[i]);
    fputc('\n', out);
}

/* aem_drive_series (crates/drive): the FMU's entry points it calls, and its signature. */
typedef struct {
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
} DriveEntries;
typedef fmi2Status DriveSeries(const DriveEntries *entries, fmi2Component c, size_t n, const double *t,
                               fmi2ValueReference input_vr, const double *input, size_t n_outputs,
                               const fmi2ValueReference *output_vrs, double *outputs, size_t *failed_at);

/* The n points start + k*h of the schedule stepped by aem_drive_series of `library`, one row each. */
static void drive_schedule(fmi2Component c, const Schedule *s, double start, double h, size_t n,
                           const char *library, FILE *out) {
    void *drive = fmu_library_open(library);
    if (!drive) die("cannot load the --drive library");
    void *address = fmu_library_symbol(drive, "aem_drive_series");
    if (!address) die("the --drive library has no aem_drive_series");
    DriveSeries *drive_series;
    memcpy(&drive_series, &address, sizeof drive_series);
    double *t = malloc(n * sizeof *t), *u = malloc(n * sizeof *u), *rows = malloc(n * N_OUTPUTS * sizeof *rows);
    if (!t || !u || !rows) die("out of memory");
    for (size_t k = 0; k < n; k++) {
        t[k] = start + (double)k * h;
        u[k] = setpoint_at(s, t[k]);
    }
    const DriveEntries entries = {fmu.SetReal, fmu.GetReal, fmu.DoStep};
    size_t failed_at = n;
    const fmi2Status status = drive_series(&entries, c, n, t, setpoint_vr, u, N_OUTPUTS, output_vrs, rows, &failed_at);
    check(status, ALLOW(fmi2OK) | ALLOW(fmi2Warning), "aem_drive_series");
    for (size_t k = 0; k < n; k++) write_row(out, t[k], rows + k * N_OUTPUTS);
    free(t);
    free(u);
    free(rows);
    if (fmu_library_close(drive) != 0) die("cannot unload the --drive library");
}

static void run_schedule(const char *schedule_path, double h, double stop, const char *out_path,
                         fmi2Integer modules, const char *parameter_file, const char *drive_path) {
    Schedule s = read_schedule(schedule_path);
    const double start = s.time[0];
    if (!(h > 0) || !(stop > start)) die("need --step > 0 and --stop after the first schedule time");
    const double n_steps = round((stop - start) / h);
    if (fabs(start + n_steps * h - stop) > 1e-9 * fmax(1.0, fabs(stop)))
        die("--stop must be the start time plus a whole number of steps");

    if (strcmp(fmu.GetTypesPlatform(), fmi2TypesPlatform) != 0) die("fmi2GetTypesPlatform is not \"default\"");
    if (strcmp(fmu.GetVersion(), fmi2Version) != 0) die("fmi2GetVersion is not \"2.0\"");

    fmi2Component c = instantiate("c_master", fmu.guid);
    if (!c) die("fmi2Instantiate returned NULL");
    OK(fmu.SetupExperiment(c, fmi2False, 0.0, start, fmi2True, stop));
    if (modules > 0) OK(fmu.SetInteger(c, &hub_vrs[0], 1, &modules));
    if (parameter_file) OK(fmu.SetString(c, &file_vr, 1, &parameter_file));
    set_setpoint(c, setpoint_at(&s, start));
    OK(fmu.EnterInitializationMode(c));
    OK_OR_WARNING(fmu.ExitInitializationMode(c));

    FILE *out = fopen(out_path, "w");
    if (!out) die("cannot write the output file");
    fputs("time,current,voltage,power,h2Flow,energy,h2Produced\n", out);
    if (drive_path) {
        drive_schedule(c, &s, start, h, (size_t)n_steps + 1, drive_path, out);
    } else {
        double values[N_OUTPUTS];
        get_outputs(c, values);
        write_row(out, start, values);
        /* Communication points are start + n*h, computed afresh each step (no running sum). */
        for (double n = 0; n < n_steps; n++) {
            const double t = start + n * h;
            set_setpoint(c, setpoint_at(&s, t));
            OK(fmu.DoStep(c, t, h, fmi2True));
            get_outputs(c, values);
            write_row(out, start + (n + 1) * h, values);
        }
    }
    if (fclose(out) != 0) die("cannot write the output file");

    double last;
    OK(fmu.GetRealStatus(c, fmi2LastSuccessfulTime, &last));
    if (fabs(last - stop) > 1e-9 * fmax(1.0, fabs(stop))) die("fmi2LastSuccessfulTime is not the stop time");
    OK(fmu.Terminate(c));
    fmu.FreeInstance(c);
    free(s.time);
    free(s.setpoint);
}

/* ------------------------------------------------------------------ memory cycles */

enum Inject { INJECT_NONE, INJECT_LEAK, INJECT_INVALID_READ };

/* One life of an instance, touching every allocation path of the FMU: instantiation (and a
 * refused one), debug logging, initialisation, steps with a changing setpoint (including a
 * clamped one, which logs a warning), FMU state get/update/serialise/deserialise/set/free,
 * a corrupted serialised state, refused calls (each must return fmi2Error, log a message and
 * leave the instance usable), terminate, reset and free. */
static void cycle(unsigned long k, enum Inject inject) {
    /* A wrong GUID: instantiation must fail with NULL (FMI 2.0, section 2.1.5). */
    if (instantiate("wrong_guid", "{not-the-guid}") != NULL) die("instantiated with a wrong GUID");

    fmi2Component c = instantiate("cycle", fmu.guid);
    if (!c) die("fmi2Instantiate returned NULL");
    fmi2String categories[] = {"logEvents"};
    OK(fmu.SetDebugLogging(c, fmi2True, 1, categories));
    OK(fmu.SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    set_setpoint(c, 60.0 + (double)(k % 41));
    if (k % 2 == 1) {
        /* Every other life is a hub of 3 to 7 modules (sequential dispatch, standby below the
         * minimum): the grouped model's allocations, its String setting and its FMU state. */
        const fmi2Integer hub_values[] = {3 + (fmi2Integer)(k % 5), 2, 1};
        OK(fmu.SetInteger(c, hub_vrs, 3, hub_values));
        fmi2String empty = "";
        OK(fmu.SetString(c, &file_vr, 1, &empty));
    }
    OK(fmu.EnterInitializationMode(c));
    fmi2String file = NULL;
    OK(fmu.GetString(c, &file_vr, 1, &file));
    if (file == NULL || file[0] != '\0') die("moduleParameterFile does not read back empty");
    OK(fmu.ExitInitializationMode(c));

    double t = 0.0, values[N_OUTPUTS];
    /* 112 %: clamped (a single module warns); 30 %: a hub stops modules to standby. */
    const double setpoints[] = {100.0, 65.0, 112.0, k % 2 == 1 ? 30.0 : 80.0};
    for (int i = 0; i < 4; i++) {
        set_setpoint(c, setpoints[i]);
        OK(fmu.DoStep(c, t, 1.5, fmi2True));
        t += 1.5;
        get_outputs(c, values);
        for (int j = 0; j < N_OUTPUTS; j++)
            if (!isfinite(values[j])) die("an output is not finite");
    }

    /* FMU state: a new copy, then an update of the same copy (FMI 2.0, section 2.1.8). */
    fmi2FMUstate state = NULL, restored = NULL;
    OK(fmu.GetFMUstate(c, &state));
    OK(fmu.DoStep(c, t, 0.5, fmi2True));
    t += 0.5;
    OK(fmu.GetFMUstate(c, &state));
    size_t size = 0;
    OK(fmu.SerializedFMUstateSize(c, state, &size));
    fmi2Byte *bytes = malloc(size);
    if (!bytes) die("out of memory");
    OK(fmu.SerializeFMUstate(c, state, bytes, size));
    OK(fmu.DoStep(c, t, 0.5, fmi2True));
    OK(fmu.DeSerializeFMUstate(c, bytes, size, &restored));
    OK(fmu.SetFMUstate(c, restored)); /* back to time t */
    OK(fmu.DoStep(c, t, 0.5, fmi2True));
    t += 0.5;
    bytes[size / 2] ^= 0x40;
    fmi2FMUstate garbage = NULL;
    REFUSED(fmu.DeSerializeFMUstate(c, bytes, size, &garbage));
    if (garbage != NULL) die("a refused deserialisation returned a state");
    if (inject == INJECT_INVALID_READ) {
        volatile fmi2Byte past_the_end = bytes[size]; /* deliberate: one byte out of bounds */
        (void)past_the_end;
    }
    free(bytes);
    OK(fmu.FreeFMUstate(c, &state));
    if (inject == INJECT_LEAK)
        restored = NULL; /* deliberate: the state is lost, never freed */
    else
        OK(fmu.FreeFMUstate(c, &restored));

    /* Refused calls; the instance keeps serving valid calls afterwards. */
    const double nan = NAN;
    REFUSED(fmu.SetReal(c, &setpoint_vr, 1, &nan));
    const fmi2ValueReference unknown = 9999;
    REFUSED(fmu.GetReal(c, &unknown, 1, values));
    REFUSED(fmu.DoStep(c, t + 5.0, 1.0, fmi2True));
    OK(fmu.DoStep(c, t, 1.0, fmi2True));
    get_outputs(c, values);

    OK(fmu.Terminate(c));
    OK(fmu.Reset(c));
    fmu.FreeInstance(c);
}

/* ------------------------------------------------------------------ main */

static const char *option(int argc, char **argv, const char *name) {
    for (int i = 1; i + 1 < argc; i += 2)
        if (strcmp(argv[i], name) == 0) return argv[i + 1];
    return NULL;
}

static double number(const char *text, const char *name) {
    char *end;
    double x = text ? strtod(text, &end) : NAN;
    if (!text || *end != '\0' || !isfinite(x)) {
        fprintf(stderr, "master: %s needs a number\n", name);
        exit(2);
    }
    return x;
}

int main(int argc, char **argv) {
    const char *dir = option(argc, argv, "--fmu-dir");
    const char *cycles = option(argc, argv, "--cycles");
    const char *schedule = option(argc, argv, "--schedule");
    const char *bad_calls = option(argc, argv, "--bad-calls");
    if (!dir || (!cycles && !schedule && !bad_calls) || argc % 2 != 1) {
        fprintf(stderr, "usage: master --fmu-dir DIR --schedule CSV --step H --stop T --out CSV\n"
                        "              [--modules N --parameter-file PATH-OR-URI] [--resource-uri URI]\n"
                        "              [--drive LIBRARY]\n"
                        "       master --fmu-dir DIR --bad-calls table\n"
                        "       master --fmu-dir DIR --cycles N [--inject leak|invalid-read]\n");
        return 2;
    }
    if (fmu_load(&fmu, dir) != 0) return 1;
    lookup_variables();
    resource_uri = option(argc, argv, "--resource-uri");
    if (!resource_uri) resource_uri = fmu.resource_uri;

    if (bad_calls) {
        if (strcmp(bad_calls, "table") != 0) die("--bad-calls takes the word table");
        if (run_bad_calls(&fmu, &sink) != 0) return 1;
    } else if (cycles) {
        const char *inject_name = option(argc, argv, "--inject");
        enum Inject inject = INJECT_NONE;
        if (inject_name && strcmp(inject_name, "leak") == 0) inject = INJECT_LEAK;
        else if (inject_name && strcmp(inject_name, "invalid-read") == 0) inject = INJECT_INVALID_READ;
        else if (inject_name) die("--inject is leak or invalid-read");
        char *end;
        const unsigned long n = strtoul(cycles, &end, 10);
        if (*end != '\0' || n == 0) die("--cycles needs a positive whole number");
        sink.quiet = 1; /* thousands of expected warnings and errors */
        for (unsigned long k = 0; k < n; k++) cycle(k, k + 1 == n ? inject : INJECT_NONE);
        printf("cycles: %lu, log messages: ok %lu, warning %lu, error %lu\n", n, sink.count[fmi2OK],
               sink.count[fmi2Warning], sink.count[fmi2Error]);
    } else {
        const char *out = option(argc, argv, "--out");
        if (!out) die("--out is required with --schedule");
        const char *modules = option(argc, argv, "--modules");
        run_schedule(schedule, number(option(argc, argv, "--step"), "--step"),
                     number(option(argc, argv, "--stop"), "--stop"), out,
                     modules ? (fmi2Integer)number(modules, "--modules") : 0,
                     option(argc, argv, "--parameter-file"), option(argc, argv, "--drive"));
    }
    return fmu_unload(&fmu) == 0 ? 0 : 1;
}
