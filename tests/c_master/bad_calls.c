/* The bad-input list of docs/robustness.md, called through a loaded FMU library: each case starts
 * from a fresh instance in its stage, makes the bad call and prints one table row
 *     | what | stage | status | first logged message |
 * exactly as tests/robustness_report.rs writes them for the in-process library. A test runs
 * this on the linux64 and the win64 binary and requires rows equal to docs/robustness.md's. The
 * one row whose message is the operating system's own text (a missing file) is left out. */
#include "bad_calls.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum Stage { INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED };
static const char *const stage_names[] = {"instantiated", "initializationMode", "stepComplete", "terminated"};

static const Fmu *fmu;
static LogSink *sink;
static fmi2CallbackFunctions callbacks;

static fmi2ValueReference vr(const char *name) { return fmu_value_reference(fmu, name); }

static fmi2Component at(enum Stage stage) {
    fmi2Component c = fmu->Instantiate("report", fmi2CoSimulation, fmu->guid, NULL, &callbacks, fmi2False, fmi2False);
    if (!c) {
        fprintf(stderr, "bad_calls: fmi2Instantiate returned NULL\n");
        exit(1);
    }
    if (stage != INSTANTIATED) fmu->EnterInitializationMode(c);
    if (stage == STEPPING || stage == TERMINATED) {
        fmu->ExitInitializationMode(c);
        fmu->DoStep(c, 0.0, 1.0, fmi2True);
    }
    if (stage == TERMINATED) fmu->Terminate(c);
    return c;
}

static fmi2Status set_real(fmi2Component c, const char *name, double value) {
    fmi2ValueReference r = vr(name);
    return fmu->SetReal(c, &r, 1, &value);
}

static fmi2Status set_integer(fmi2Component c, const char *name, fmi2Integer value) {
    fmi2ValueReference r = vr(name);
    return fmu->SetInteger(c, &r, 1, &value);
}

/* A serialised FMU state of an instance that has stepped once: *size bytes, malloc'ed. */
static fmi2Byte *serialized_state(size_t *size) {
    fmi2Component c = at(STEPPING);
    fmi2FMUstate state = NULL;
    fmu->GetFMUstate(c, &state);
    fmu->SerializedFMUstateSize(c, state, size);
    fmi2Byte *bytes = malloc(*size);
    if (!bytes) exit(1);
    fmu->SerializeFMUstate(c, state, bytes, *size);
    fmu->FreeFMUstate(c, &state);
    fmu->FreeInstance(c);
    return bytes;
}

static fmi2Status deserialize(fmi2Component c, const fmi2Byte *bytes, size_t size) {
    fmi2FMUstate state = NULL;
    fmi2Status s = fmu->DeSerializeFMUstate(c, bytes, size, &state);
    if (state) fmu->FreeFMUstate(c, &state);
    return s;
}

/* One case: `call` gets the instance and the serialised state; returns the status. */
typedef fmi2Status (*Call)(fmi2Component c, const fmi2Byte *state, size_t size);
typedef struct {
    const char *what;
    enum Stage stage;
    Call call;
} Case;

static void print_cell(const char *text) {
    for (const char *p = text; *p; p++) {
        if (*p == '|') fputs("\\|", stdout);
        else if (*p == '\n') fputc(' ', stdout);
        else fputc(*p, stdout);
    }
}

static void print_row(const char *what, const char *stage, const char *status, const char *message) {
    printf("| %s | %s | %s | ", what, stage, status);
    print_cell(message);
    printf(" |\n");
}

#define CASE(name) static fmi2Status name(fmi2Component c, const fmi2Byte *state, size_t size)
#define UNUSED (void)c, (void)state, (void)size
CASE(setpoint_nan) { UNUSED; return set_real(c, "setpoint", NAN); }
CASE(setpoint_inf) { UNUSED; return set_real(c, "setpoint", INFINITY); }
CASE(setpoint_minus_inf) { UNUSED; return set_real(c, "setpoint", -INFINITY); }
CASE(setpoint_clamped) { UNUSED; return set_real(c, "setpoint", 30.0); }
CASE(parameter_nan) { UNUSED; return set_real(c, "gain", NAN); }
CASE(set_unknown_vr) { UNUSED; const fmi2ValueReference r = 99; const double x = 1.0; return fmu->SetReal(c, &r, 1, &x); }
CASE(get_unknown_vr) { UNUSED; const fmi2ValueReference r = 4294967295u; double x; return fmu->GetReal(c, &r, 1, &x); }
CASE(set_output) { UNUSED; return set_real(c, "current", 1.0); }
CASE(set_fixed_late) { UNUSED; return set_real(c, "gain", 0.6); }
CASE(get_before_init) { UNUSED; const fmi2ValueReference r = 1; double x; return fmu->GetReal(c, &r, 1, &x); }
CASE(step_before_init) { UNUSED; return fmu->DoStep(c, 0.0, 1.0, fmi2True); }
CASE(step_after_terminate) { UNUSED; return fmu->DoStep(c, 1.0, 1.0, fmi2True); }
CASE(exit_twice) { UNUSED; return fmu->ExitInitializationMode(c); }
CASE(step_minus_one) { UNUSED; return fmu->DoStep(c, 1.0, -1.0, fmi2True); }
CASE(step_zero) { UNUSED; return fmu->DoStep(c, 1.0, 0.0, fmi2True); }
CASE(step_nan) { UNUSED; return fmu->DoStep(c, 1.0, NAN, fmi2True); }
CASE(step_inf) { UNUSED; return fmu->DoStep(c, 1.0, INFINITY, fmi2True); }
CASE(step_huge) { UNUSED; return fmu->DoStep(c, 1.0, 1e306, fmi2True); }
CASE(step_past_stop) {
    UNUSED;
    fmu->SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, 10.0);
    fmu->EnterInitializationMode(c);
    fmu->ExitInitializationMode(c);
    return fmu->DoStep(c, 0.0, 20.0, fmi2True);
}
CASE(step_off_point) { UNUSED; return fmu->DoStep(c, 2.0, 1.0, fmi2True); }
CASE(tau_negative) { UNUSED; set_real(c, "tauPole1", -1.0); return fmu->ExitInitializationMode(c); }
CASE(window_inverted) {
    UNUSED;
    set_real(c, "minSetpoint", 90.0);
    set_real(c, "maxSetpoint", 80.0);
    return fmu->ExitInitializationMode(c);
}
CASE(double_pole) { UNUSED; set_real(c, "tauPole2", 1.995); return fmu->ExitInitializationMode(c); }
CASE(gain_overflow) { UNUSED; set_real(c, "gain", 1e200); return fmu->ExitInitializationMode(c); }
CASE(null_vr_array) { UNUSED; double x; return fmu->GetReal(c, NULL, 1, &x); }
CASE(null_value_array) { UNUSED; const fmi2ValueReference r = 1; return fmu->GetReal(c, &r, 1, NULL); }
CASE(null_component) { UNUSED; return fmu->DoStep(NULL, 0.0, 1.0, fmi2True); }
CASE(foreign_component) {
    UNUSED;
    unsigned long long foreign[512];
    for (int i = 0; i < 512; i++) foreign[i] = 7;
    return fmu->DoStep((fmi2Component)foreign, 0.0, 1.0, fmi2True);
}
CASE(unknown_category) { UNUSED; fmi2String names[] = {"nope"}; return fmu->SetDebugLogging(c, fmi2True, 1, names); }
CASE(null_category) { UNUSED; fmi2String names[] = {NULL}; return fmu->SetDebugLogging(c, fmi2True, 1, names); }
CASE(set_null_state) { UNUSED; return fmu->SetFMUstate(c, NULL); }
CASE(foreign_state) {
    UNUSED;
    unsigned long long foreign[512];
    for (int i = 0; i < 512; i++) foreign[i] = 9;
    return fmu->SetFMUstate(c, (fmi2FMUstate)foreign);
}
/* Deserialises a copy of the state whose byte `at` is `value`. */
static fmi2Status deserialize_changed(fmi2Component c, const fmi2Byte *state, size_t size, size_t at, fmi2Byte value) {
    fmi2Byte *copy = malloc(size);
    if (!copy) exit(1);
    memcpy(copy, state, size);
    copy[at] = value;
    fmi2Status s = deserialize(c, copy, size);
    free(copy);
    return s;
}
CASE(flipped_byte) { return deserialize_changed(c, state, size, size / 2, (fmi2Byte)(state[size / 2] ^ 1)); }
CASE(truncated) { return deserialize(c, state, size - 1); }
CASE(other_version) { return deserialize_changed(c, state, size, 8, 2); }
CASE(buffer_too_small) {
    UNUSED;
    fmi2FMUstate st = NULL;
    fmu->GetFMUstate(c, &st);
    fmi2Byte buffer[8] = {0};
    fmi2Status s = fmu->SerializeFMUstate(c, st, buffer, sizeof buffer);
    fmu->FreeFMUstate(c, &st);
    return s;
}
static fmi2Status derivative(fmi2Component c, fmi2ValueReference r, fmi2Integer order, double value) {
    return fmu->SetRealInputDerivatives(c, &r, 1, &order, &value);
}
CASE(derivative_order0) { UNUSED; return derivative(c, 0, 0, 0.1); }
CASE(derivative_order2) { UNUSED; return derivative(c, 0, 2, 0.1); }
CASE(derivative_of_output) { UNUSED; return derivative(c, 1, 1, 0.1); }
CASE(derivative_nan) { UNUSED; return derivative(c, 0, 1, NAN); }
CASE(get_unknown_integer) { UNUSED; const fmi2ValueReference r = 0; fmi2Integer x; return fmu->GetInteger(c, &r, 1, &x); }
CASE(set_integer_output) { UNUSED; return set_integer(c, "modulesRunning", 3); }
CASE(no_modules) { UNUSED; set_integer(c, "nModules", 0); return fmu->ExitInitializationMode(c); }
CASE(dispatch_nine) { UNUSED; set_integer(c, "dispatch", 9); return fmu->ExitInitializationMode(c); }
CASE(sequential_at_minimum) {
    UNUSED;
    set_integer(c, "nModules", 10);
    set_integer(c, "dispatch", 2);
    return fmu->ExitInitializationMode(c);
}
CASE(spread_too_wide) { UNUSED; set_real(c, "parameterSpread", 0.9); return fmu->ExitInitializationMode(c); }
CASE(cold_start_negative) {
    UNUSED;
    set_integer(c, "belowMinimum", 2);
    set_real(c, "coldStartTime", -1.0);
    return fmu->ExitInitializationMode(c);
}
CASE(null_string) { UNUSED; const fmi2ValueReference r = vr("moduleParameterFile"); fmi2String v[] = {NULL}; return fmu->SetString(c, &r, 1, v); }
CASE(modules_late) { UNUSED; return set_integer(c, "nModules", 4); }
CASE(hub_derivative) { UNUSED; set_integer(c, "nModules", 4); return derivative(c, 0, 1, 0.1); }
CASE(output_derivatives) {
    UNUSED;
    const fmi2ValueReference r = 1;
    const fmi2Integer order = 1;
    double x;
    return fmu->GetRealOutputDerivatives(c, &r, 1, &order, &x);
}
CASE(directional_derivative) {
    UNUSED;
    const fmi2ValueReference unknown = 1, known = 0;
    const double seed = 1.0;
    double x;
    return fmu->GetDirectionalDerivative(c, &unknown, 1, &known, 1, &seed, &x);
}
CASE(cancel_step) { UNUSED; return fmu->CancelStep(c); }
CASE(do_step_status) { UNUSED; fmi2Status s; return fmu->GetStatus(c, fmi2DoStepStatus, &s); }

static const Case cases[] = {
    {"setpoint = NaN", STEPPING, setpoint_nan},
    {"setpoint = +inf", STEPPING, setpoint_inf},
    {"setpoint = -inf", STEPPING, setpoint_minus_inf},
    {"setpoint outside [60, 100] % (clamped)", STEPPING, setpoint_clamped},
    {"parameter = NaN", INITIALIZATION, parameter_nan},
    {"unknown value reference (fmi2SetReal)", STEPPING, set_unknown_vr},
    {"unknown value reference (fmi2GetReal)", STEPPING, get_unknown_vr},
    {"setting an output", STEPPING, set_output},
    {"setting a fixed parameter after initialisation", STEPPING, set_fixed_late},
    {"fmi2GetReal before initialisation mode", INSTANTIATED, get_before_init},
    {"fmi2DoStep before initialisation", INSTANTIATED, step_before_init},
    {"fmi2DoStep after fmi2Terminate", TERMINATED, step_after_terminate},
    {"fmi2ExitInitializationMode twice", STEPPING, exit_twice},
    {"step size -1 s", STEPPING, step_minus_one},
    {"step size 0 s", STEPPING, step_zero},
    {"step size NaN", STEPPING, step_nan},
    {"step size +inf", STEPPING, step_inf},
    {"step size 1e306 s (the energy total would overflow)", STEPPING, step_huge},
    {"step past stopTime of fmi2SetupExperiment", INSTANTIATED, step_past_stop},
    {"communication point off by 1 s", STEPPING, step_off_point},
    {"tauPole1 = -1 s at initialisation", INITIALIZATION, tau_negative},
    {"minSetpoint > maxSetpoint at initialisation", INITIALIZATION, window_inverted},
    {"tauPole1 = tauPole2 at initialisation", INITIALIZATION, double_pole},
    {"gain = 1e200 A/% at initialisation (overflow)", INITIALIZATION, gain_overflow},
    {"null value-reference array", STEPPING, null_vr_array},
    {"null value array", STEPPING, null_value_array},
    {"null component", STEPPING, null_component},
    {"component pointer not made by this FMU", STEPPING, foreign_component},
    {"unknown log category", STEPPING, unknown_category},
    {"null log category", STEPPING, null_category},
    {"fmi2SetFMUstate(NULL)", STEPPING, set_null_state},
    {"FMU state pointer not made by this FMU", STEPPING, foreign_state},
    {"serialised state with a flipped byte", STEPPING, flipped_byte},
    {"serialised state truncated", STEPPING, truncated},
    {"serialised state of another format version", STEPPING, other_version},
    {"serialisation buffer too small", STEPPING, buffer_too_small},
    {"input derivative of order 0", STEPPING, derivative_order0},
    {"input derivative of order 2 (ignored)", STEPPING, derivative_order2},
    {"input derivative of an output", STEPPING, derivative_of_output},
    {"input derivative NaN", STEPPING, derivative_nan},
    {"unknown value reference (fmi2GetInteger)", STEPPING, get_unknown_integer},
    {"setting an Integer output", STEPPING, set_integer_output},
    {"nModules = 0 at initialisation", INITIALIZATION, no_modules},
    {"dispatch = 9 at initialisation", INITIALIZATION, dispatch_nine},
    {"sequential dispatch with belowMinimum = 0 at initialisation", INITIALIZATION, sequential_at_minimum},
    {"parameterSpread = 0.9 at initialisation", INITIALIZATION, spread_too_wide},
    {"coldStartTime = -1 s at initialisation", INITIALIZATION, cold_start_negative},
    {"fmi2SetString with a null string", INITIALIZATION, null_string},
    {"nModules set after initialisation", STEPPING, modules_late},
    {"setpoint derivative for a hub", INITIALIZATION, hub_derivative},
    {"fmi2GetRealOutputDerivatives", STEPPING, output_derivatives},
    {"fmi2GetDirectionalDerivative", STEPPING, directional_derivative},
    {"fmi2CancelStep", STEPPING, cancel_step},
    {"fmi2GetStatus(fmi2DoStepStatus)", STEPPING, do_step_status},
};

/* fmi2Instantiate that must return NULL and log why. */
static void instantiate_case(const char *what, const char *name, fmi2Type type, const char *guid) {
    sink->first[0] = '\0';
    fmi2Component c = fmu->Instantiate(name, type, guid, NULL, &callbacks, fmi2False, fmi2False);
    if (c) {
        fprintf(stderr, "bad_calls: %s returned an instance\n", what);
        exit(1);
    }
    print_row(what, "(none)", "NULL", sink->first);
}

int run_bad_calls(const Fmu *loaded, LogSink *log) {
    fmu = loaded;
    sink = log;
    sink->quiet = 1;
    callbacks = (fmi2CallbackFunctions){fmu_logger, calloc, free, NULL, sink};
    size_t size = 0;
    fmi2Byte *state = serialized_state(&size);
    printf("| bad input | stage | status | logged message |\n|---|---|---|---|\n");
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        fmi2Component c = at(cases[i].stage);
        sink->first[0] = '\0';
        fmi2Status status = cases[i].call(c, state, size);
        if (status == fmi2OK) {
            fprintf(stderr, "bad_calls: %s was accepted\n", cases[i].what);
            return 1;
        }
        print_row(cases[i].what, stage_names[cases[i].stage], fmu_status_name(status),
                  sink->first[0] ? sink->first : "(no instance to log through)");
        fmu->FreeInstance(c);
    }
    free(state);
    instantiate_case("fmi2Instantiate with a wrong GUID", "report", fmi2CoSimulation, "{0}");
    instantiate_case("fmi2Instantiate for model exchange", "report", fmi2ModelExchange, fmu->guid);
    instantiate_case("fmi2Instantiate with an empty instance name", "", fmi2CoSimulation, fmu->guid);
    return 0;
}
