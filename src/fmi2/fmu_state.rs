//! FMU states for fmi2GetFMUstate/fmi2SetFMUstate and their serialised form.
//!
//! Serialised layout (little endian): magic "AEMFMUST", format version (u32), payload
//! length (u32), payload, CRC-32 of everything before it (u32). The payload holds the GUID
//! and every field of [`SavedState`] in order: flags, parameters, settings (the reserves
//! offered among them, then the thermal, the grid-side and the ageing ones), inputs, times, the module parameter file's name and its parameter
//! sets, the reserves' state (FFR's, and what was logged), then the plant (a module's state,
//! or a hub's groups and totals). On the way back in,
//! magic, version, length, checksum, GUID, enum codes, finiteness and the plant's
//! consistency with its settings are all checked.

use crate::model_description::GUID;
use aem_model::hub::{Group, HubSnapshot, HubTotals};
use aem_model::operation::UnitState;
use aem_model::{
    AgeingParameters, CurrentState, Drift, FastReserve, GridParameters, ModuleState,
    OperatingState, Parameters, PlantSettings, PlantSnapshot, ReserveSettings, ThermalParameters,
};

use super::state_error::StateError;
use super::state_machine::FmiState;
use super::variables::Inputs;

/// The first bytes of every serialised state.
pub const MAGIC: &[u8; 8] = b"AEMFMUST";
/// Version of the serialised format; bump it whenever the payload changes.
pub const FORMAT_VERSION: u32 = 11;
const SAVED_MAGIC: u64 = 0x4145_4d5f_5354_4154; // "AEM_STAT"
const PLANT_NONE: u8 = 0;
const PLANT_MODULE: u8 = 1;
const PLANT_HUB: u8 = 2;

/// The reserves' state between steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReserveState {
    /// FFR's state.
    pub fast: FastReserve,
    /// Whether the window keeps the hub short of the request (logged once).
    pub shortfall: bool,
    /// Whether the request asks for more draw (logged once).
    pub increase: bool,
}

/// A complete copy of an instance's state.
#[derive(Clone, Debug, PartialEq)]
#[repr(C)]
pub struct SavedState {
    magic: u64,
    /// FMI state of the instance.
    pub fmi_state: FmiState,
    /// Parameters (they may differ from the start values).
    pub params: Parameters,
    /// Hub settings.
    pub settings: PlantSettings,
    /// Input values as last set.
    pub inputs: Inputs,
    /// The setpoint's derivative for the next step [%/s].
    pub setpoint_slope: f64,
    /// Whether the setpoint is outside the window (a warning was logged).
    pub excursion: bool,
    /// Communication time [s].
    pub time: f64,
    /// stopTime of fmi2SetupExperiment, if defined [s].
    pub stop_time: Option<f64>,
    /// `moduleParameterFile`.
    pub module_parameter_file: String,
    /// The per-module parameter sets read from it at initialisation.
    pub module_sets: Option<Vec<Parameters>>,
    /// The reserves' state.
    pub reserve: ReserveState,
    /// The plant's state, once initialised.
    pub plant: Option<PlantSnapshot>,
}

impl SavedState {
    /// A new saved state.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        fmi_state: FmiState,
        params: Parameters,
        settings: PlantSettings,
        inputs: Inputs,
        setpoint_slope: f64,
        excursion: bool,
        time: f64,
        stop_time: Option<f64>,
        module_parameter_file: String,
        module_sets: Option<Vec<Parameters>>,
        reserve: ReserveState,
        plant: Option<PlantSnapshot>,
    ) -> Self {
        SavedState {
            magic: SAVED_MAGIC,
            fmi_state,
            params,
            settings,
            inputs,
            setpoint_slope,
            excursion,
            time,
            stop_time,
            module_parameter_file,
            module_sets,
            reserve,
            plant,
        }
    }

    /// Whether `ptr` is aligned and its memory carries a saved state's magic (a cheap guard
    /// against foreign pointers; reads only the magic word, as raw bytes).
    ///
    /// # Safety
    /// `ptr` must be non-null and point to at least `size_of::<SavedState>()` readable bytes.
    pub unsafe fn has_magic(ptr: *const SavedState) -> bool {
        ptr.is_aligned()
            && unsafe { std::ptr::addr_of!((*ptr).magic).read_unaligned() } == SAVED_MAGIC
    }

    /// Marks the memory as no longer a state, just before it is freed.
    pub fn invalidate(&mut self) {
        self.magic = 0;
    }

    /// The serialised bytes.
    pub fn serialize(&self) -> Vec<u8> {
        let mut w = Writer(Vec::with_capacity(512));
        w.u32(GUID.len() as u32);
        w.bytes(GUID.as_bytes());
        w.u8(self.fmi_state.code());
        w.u8(self.excursion as u8);
        w.u8(self.stop_time.is_some() as u8);
        for x in parameter_values(&self.params) {
            w.f64(x);
        }
        let s = &self.settings;
        for i in [
            s.n_modules,
            s.dispatch,
            s.below_minimum,
            s.spread_seed,
            s.initial_standby,
        ] {
            w.u32(i as u32);
        }
        w.u8(s.power_input as u8);
        for x in [
            s.hysteresis,
            s.cold_start_time,
            s.warm_start_time,
            s.start_power,
            s.standby_power,
            s.standby_duration,
            s.stop_duration,
            s.parameter_spread,
            s.dispatch_target,
        ] {
            w.f64(x);
        }
        let r = &s.reserve;
        for x in [
            r.fcr_n,
            r.fcr_d_up,
            r.fcr_d_down,
            r.fcr,
            r.ffr,
            r.ffr_trigger,
            r.ffr_duration,
        ] {
            w.f64(x);
        }
        w.u8(r.compensation as u8);
        w.f64(r.filter_zero);
        w.u8(s.thermal_model as u8);
        w.u32(s.thermal.n_cells as u32);
        for x in thermal_values(&s.thermal) {
            w.f64(x);
        }
        let g = &s.grid;
        w.u8(g.grid_side_reference as u8);
        for x in [
            g.auxiliary_power,
            g.supply_no_load_loss,
            g.supply_loss_voltage,
            g.supply_loss_resistance,
        ] {
            w.f64(x);
        }
        let a = &s.ageing;
        for x in [
            a.drift_per_running_hour,
            a.drift_per_start,
            a.reversible_drift,
            a.drift_build_up_time,
            a.drift_recovery_time,
            a.initial_drift,
        ] {
            w.f64(x);
        }
        for x in [
            self.inputs.setpoint,
            self.inputs.power_reference,
            self.inputs.frequency,
            self.inputs.ambient_temperature,
            self.setpoint_slope,
            self.time,
            self.stop_time.unwrap_or(0.0),
        ] {
            w.f64(x);
        }
        w.u32(self.module_parameter_file.len() as u32);
        w.bytes(self.module_parameter_file.as_bytes());
        w.u8(self.module_sets.is_some() as u8);
        let sets = self.module_sets.as_deref().unwrap_or(&[]);
        w.u32(sets.len() as u32);
        for set in sets {
            for x in parameter_values(set) {
                w.f64(x);
            }
        }
        let (code, until) = match self.reserve.fast {
            FastReserve::Armed => (0, 0.0),
            FastReserve::Active { until } => (1, until),
            FastReserve::Spent => (2, 0.0),
        };
        w.u8(code);
        w.f64(until);
        w.u8(self.reserve.shortfall as u8);
        w.u8(self.reserve.increase as u8);
        match &self.plant {
            None => w.u8(PLANT_NONE),
            Some(PlantSnapshot::Module(m)) => {
                w.u8(PLANT_MODULE);
                for x in [
                    m.time,
                    m.current.z1,
                    m.current.z2,
                    m.current.current,
                    m.energy,
                    m.h2_produced,
                    m.temperature,
                    m.charge,
                    m.current_squared,
                    m.drift.irreversible,
                    m.drift.reversible,
                ] {
                    w.f64(x);
                }
            }
            Some(PlantSnapshot::Hub(h)) => {
                w.u8(PLANT_HUB);
                w.u32(h.groups.len() as u32);
                for g in &h.groups {
                    w.u32(g.count);
                    w.u32(g.kind);
                    w.u8(g.active as u8);
                    w.u8(g.unit.state.code() as u8);
                    for x in [
                        g.unit.timer,
                        g.unit.current.z1,
                        g.unit.current.z2,
                        g.unit.current.current,
                        g.running,
                        g.unit.temperature,
                        g.unit.drift.irreversible,
                        g.unit.drift.reversible,
                    ] {
                        w.f64(x);
                    }
                    w.u64(g.starts);
                }
                w.u32(h.running_target);
                let t = &h.totals;
                for x in [t.time, t.energy, t.h2_produced, t.running] {
                    w.f64(x);
                }
                w.u64(t.starts);
                w.u64(t.warm_starts);
                for x in [t.charge, t.current_squared, t.starting] {
                    w.f64(x);
                }
            }
        }
        let payload = w.0;
        let mut out = Vec::with_capacity(payload.len() + 20);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        out.extend_from_slice(&payload);
        let crc = crc32fast::hash(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        out
    }

    /// Parses bytes made by [`SavedState::serialize`], refusing anything else with a reason.
    pub fn deserialize(bytes: &[u8]) -> Result<SavedState, StateError> {
        let mut r = Reader { bytes, pos: 0 };
        if r.take(8)? != MAGIC {
            return Err(StateError::BadMagic);
        }
        let version = r.u32()?;
        if version != FORMAT_VERSION {
            return Err(StateError::Version {
                found: version,
                reads: FORMAT_VERSION,
            });
        }
        let len = r.u32()? as usize;
        if bytes.len() != 16 + len + 4 {
            return Err(StateError::Length {
                actual: bytes.len(),
                announced: 16 + len + 4,
            });
        }
        let crc = u32::from_le_bytes(
            bytes[16 + len..]
                .try_into()
                .map_err(|_| StateError::TruncatedChecksum)?,
        );
        if crc != crc32fast::hash(&bytes[..16 + len]) {
            return Err(StateError::Checksum);
        }
        r.bytes = &bytes[..16 + len];
        let guid_len = r.u32()? as usize;
        if r.take(guid_len)? != GUID.as_bytes() {
            return Err(StateError::OtherModel);
        }
        let fmi_state = FmiState::from_code(r.u8()?).ok_or(StateError::UnknownFmiState)?;
        let excursion = r.flag()?;
        let has_stop = r.flag()?;
        let params = read_parameters(&mut r)?;
        let (n_modules, dispatch, below_minimum, spread_seed, initial_standby) = (
            r.u32()? as i32,
            r.u32()? as i32,
            r.u32()? as i32,
            r.u32()? as i32,
            r.u32()? as i32,
        );
        let power_input = r.flag()?;
        let mut x = [0.0; 9];
        for v in x.iter_mut() {
            *v = r.finite()?;
        }
        let settings = PlantSettings {
            n_modules,
            dispatch,
            below_minimum,
            power_input,
            hysteresis: x[0],
            cold_start_time: x[1],
            warm_start_time: x[2],
            start_power: x[3],
            standby_power: x[4],
            standby_duration: x[5],
            stop_duration: x[6],
            parameter_spread: x[7],
            dispatch_target: x[8],
            spread_seed,
            initial_standby,
            reserve: ReserveSettings {
                fcr_n: r.finite()?,
                fcr_d_up: r.finite()?,
                fcr_d_down: r.finite()?,
                fcr: r.finite()?,
                ffr: r.finite()?,
                ffr_trigger: r.finite()?,
                ffr_duration: r.finite()?,
                compensation: r.flag()?,
                filter_zero: r.finite()?,
            },
            thermal_model: r.flag()?,
            thermal: read_thermal(&mut r)?,
            grid: GridParameters {
                grid_side_reference: r.flag()?,
                auxiliary_power: r.finite()?,
                supply_no_load_loss: r.finite()?,
                supply_loss_voltage: r.finite()?,
                supply_loss_resistance: r.finite()?,
            },
            ageing: AgeingParameters {
                drift_per_running_hour: r.finite()?,
                drift_per_start: r.finite()?,
                reversible_drift: r.finite()?,
                drift_build_up_time: r.finite()?,
                drift_recovery_time: r.finite()?,
                initial_drift: r.finite()?,
            },
        };
        let inputs = Inputs {
            setpoint: r.finite()?,
            power_reference: r.finite()?,
            frequency: r.finite()?,
            ambient_temperature: r.finite()?,
        };
        let (setpoint_slope, time, stop) = (r.finite()?, r.finite()?, r.finite()?);
        let path_len = r.u32()? as usize;
        let module_parameter_file = String::from_utf8(r.take(path_len)?.to_vec())
            .map_err(|_| StateError::FileNameNotUtf8)?;
        let has_sets = r.flag()?;
        let set_count = r.u32()? as usize;
        if set_count
            .checked_mul(8 * 11)
            .is_none_or(|b| b > r.bytes.len() - r.pos)
            || (!has_sets && set_count > 0)
        {
            return Err(StateError::Truncated(Some("parameter sets")));
        }
        let mut sets = Vec::with_capacity(set_count);
        for _ in 0..set_count {
            sets.push(read_parameters(&mut r)?);
        }
        let module_sets = has_sets.then_some(sets);
        let (code, until) = (r.u8()?, r.finite()?);
        let fast = match code {
            0 => FastReserve::Armed,
            1 => FastReserve::Active { until },
            2 => FastReserve::Spent,
            other => return Err(StateError::UnknownFfrState(other)),
        };
        let reserve = ReserveState {
            fast,
            shortfall: r.flag()?,
            increase: r.flag()?,
        };
        let plant = match r.u8()? {
            PLANT_NONE => None,
            PLANT_MODULE => {
                let mut m = [0.0; 11];
                for v in m.iter_mut() {
                    *v = r.finite()?;
                }
                let current = CurrentState {
                    z1: m[1],
                    z2: m[2],
                    current: m[3],
                };
                Some(PlantSnapshot::Module(ModuleState {
                    time: m[0],
                    current,
                    energy: m[4],
                    h2_produced: m[5],
                    temperature: m[6],
                    charge: m[7],
                    current_squared: m[8],
                    drift: Drift {
                        irreversible: m[9],
                        reversible: m[10],
                    },
                }))
            }
            PLANT_HUB => Some(PlantSnapshot::Hub(read_hub(&mut r)?)),
            other => return Err(StateError::UnknownPlantKind(other)),
        };
        if r.pos != r.bytes.len() {
            return Err(StateError::TrailingBytes);
        }
        if plant.is_some() {
            for p in std::iter::once(&params).chain(module_sets.iter().flatten()) {
                p.validate().map_err(StateError::InvalidParameters)?;
            }
            settings.config().map_err(StateError::InvalidSettings)?;
        }
        let stop_time = has_stop.then_some(stop);
        Ok(SavedState::new(
            fmi_state,
            params,
            settings,
            inputs,
            setpoint_slope,
            excursion,
            time,
            stop_time,
            module_parameter_file,
            module_sets,
            reserve,
            plant,
        ))
    }
}

/// The parameters in serialised order.
fn parameter_values(p: &Parameters) -> [f64; 11] {
    [
        p.gain,
        p.tau_zero,
        p.tau_pole1,
        p.tau_pole2,
        p.ramp_up_limit,
        p.voltage_intercept,
        p.ohmic_resistance,
        p.h2_coefficient,
        p.nominal_current,
        p.min_setpoint,
        p.max_setpoint,
    ]
}

/// Parameters in the order of [`parameter_values`].
/// The thermal parameters' Real values in their serialised order (nCells is written before).
fn thermal_values(t: &ThermalParameters) -> [f64; 10] {
    [
        t.initial_temperature,
        t.heat_capacity,
        t.thermal_resistance,
        t.cooling_setpoint,
        t.max_cooling_power,
        t.nominal_temperature,
        t.voltage_temperature_coefficient,
        t.resistance_temperature_coefficient,
        t.warm_start_temperature,
        t.standby_heater_power,
    ]
}

fn read_thermal(r: &mut Reader) -> Result<ThermalParameters, StateError> {
    let n_cells = r.u32()? as i32;
    let mut x = [0.0; 10];
    for v in x.iter_mut() {
        *v = r.finite()?;
    }
    Ok(ThermalParameters {
        initial_temperature: x[0],
        heat_capacity: x[1],
        thermal_resistance: x[2],
        cooling_setpoint: x[3],
        max_cooling_power: x[4],
        n_cells,
        nominal_temperature: x[5],
        voltage_temperature_coefficient: x[6],
        resistance_temperature_coefficient: x[7],
        warm_start_temperature: x[8],
        standby_heater_power: x[9],
    })
}

fn read_parameters(r: &mut Reader) -> Result<Parameters, StateError> {
    let mut p = [0.0; 11];
    for v in p.iter_mut() {
        *v = r.finite()?;
    }
    Ok(Parameters {
        gain: p[0],
        tau_zero: p[1],
        tau_pole1: p[2],
        tau_pole2: p[3],
        ramp_up_limit: p[4],
        voltage_intercept: p[5],
        ohmic_resistance: p[6],
        h2_coefficient: p[7],
        nominal_current: p[8],
        min_setpoint: p[9],
        max_setpoint: p[10],
    })
}

/// A hub's groups and totals; the group count is bounded by the bytes that hold them.
fn read_hub(r: &mut Reader) -> Result<HubSnapshot, StateError> {
    const GROUP_BYTES: usize = 4 + 4 + 1 + 1 + 8 * 8 + 8;
    let n = r.u32()? as usize;
    if n.checked_mul(GROUP_BYTES)
        .is_none_or(|b| b > r.bytes.len() - r.pos)
    {
        return Err(StateError::Truncated(Some("hub groups")));
    }
    let mut groups = Vec::with_capacity(n);
    for _ in 0..n {
        let (count, kind) = (r.u32()?, r.u32()?);
        let active = r.flag()?;
        let code = r.u8()?;
        let state = OperatingState::ALL
            .into_iter()
            .find(|s| s.code() == code as i32)
            .ok_or(StateError::UnknownOperatingState(code))?;
        let (timer, z1, z2, current, running, temperature) = (
            r.finite()?,
            r.finite()?,
            r.finite()?,
            r.finite()?,
            r.finite()?,
            r.finite()?,
        );
        let drift = Drift {
            irreversible: r.finite()?,
            reversible: r.finite()?,
        };
        let starts = r.u64()?;
        groups.push(Group {
            count,
            kind,
            active,
            unit: UnitState {
                state,
                timer,
                current: CurrentState { z1, z2, current },
                temperature,
                drift,
            },
            running,
            starts,
        });
    }
    let running_target = r.u32()?;
    let totals = HubTotals {
        time: r.finite()?,
        energy: r.finite()?,
        h2_produced: r.finite()?,
        running: r.finite()?,
        starts: r.u64()?,
        warm_starts: r.u64()?,
        charge: r.finite()?,
        current_squared: r.finite()?,
        starting: r.finite()?,
    };
    Ok(HubSnapshot {
        groups,
        running_target,
        totals,
    })
}

struct Writer(Vec<u8>);

impl Writer {
    fn u8(&mut self, x: u8) {
        self.0.push(x);
    }
    fn u32(&mut self, x: u32) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn u64(&mut self, x: u64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn f64(&mut self, x: f64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], StateError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|e| *e <= self.bytes.len())
            .ok_or(StateError::Truncated(None))?;
        let slice = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(slice)
    }
    fn u8(&mut self) -> Result<u8, StateError> {
        Ok(self.take(1)?[0])
    }
    fn flag(&mut self) -> Result<bool, StateError> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            other => Err(StateError::InvalidFlag(other)),
        }
    }
    fn u32(&mut self) -> Result<u32, StateError> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u64(&mut self) -> Result<u64, StateError> {
        let mut a = [0u8; 8];
        a.copy_from_slice(self.take(8)?);
        Ok(u64::from_le_bytes(a))
    }
    /// A finite f64 (saved states hold only finite numbers).
    fn finite(&mut self) -> Result<f64, StateError> {
        let mut a = [0u8; 8];
        a.copy_from_slice(self.take(8)?);
        let x = f64::from_le_bytes(a);
        if x.is_finite() {
            Ok(x)
        } else {
            Err(StateError::NonFinite(self.pos - 8))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// FFR active until 130 s, a shortfall logged.
    const RESERVE: ReserveState = ReserveState {
        fast: FastReserve::Active { until: 130.0 },
        shortfall: true,
        increase: false,
    };

    fn sample() -> SavedState {
        let module = ModuleState {
            time: 12.5,
            current: CurrentState {
                z1: 40.0,
                z2: 38.5,
                current: 39.25,
            },
            energy: 1.0e6,
            h2_produced: 33.0,
            temperature: 301.25,
            charge: 451.5,
            current_squared: 18_000.25,
            drift: Drift {
                irreversible: 0.125,
                reversible: 0.0625,
            },
        };
        let inputs = Inputs {
            setpoint: 73.0,
            power_reference: 1.5e6,
            frequency: 49.8,
            ambient_temperature: 270.5,
        };
        let plant = Some(PlantSnapshot::Module(module));
        let settings = PlantSettings {
            thermal_model: true,
            thermal: ThermalParameters {
                heat_capacity: 12_345.0,
                n_cells: 17,
                ..ThermalParameters::default()
            },
            grid: GridParameters {
                auxiliary_power: 150.0,
                supply_no_load_loss: 40.0,
                supply_loss_voltage: 0.75,
                supply_loss_resistance: 0.002,
                grid_side_reference: true,
            },
            ageing: AgeingParameters {
                drift_per_running_hour: 5e-6,
                drift_per_start: 1e-4,
                reversible_drift: 0.25,
                drift_build_up_time: 7_200.0,
                drift_recovery_time: 1_800.0,
                initial_drift: 0.125,
            },
            ..PlantSettings::default()
        };
        SavedState::new(
            FmiState::StepComplete,
            Parameters::default(),
            settings,
            inputs,
            -0.25,
            false,
            112.5,
            Some(3600.0),
            String::new(),
            None,
            RESERVE,
            plant,
        )
    }

    fn hub_sample() -> SavedState {
        let reserve = aem_model::ReserveSettings {
            fcr_d_up: 5_000.0,
            ffr: 2_000.0,
            compensation: true,
            ..Default::default()
        };
        let settings = PlantSettings {
            n_modules: 10,
            dispatch: 2,
            below_minimum: 1,
            power_input: true,
            reserve,
            ageing: AgeingParameters {
                drift_per_start: 1e-3,
                reversible_drift: 0.5,
                ..AgeingParameters::default()
            },
            ..PlantSettings::default()
        };
        let config = settings.config().unwrap();
        let sets = vec![
            Parameters::default(),
            Parameters {
                gain: 0.5,
                ..Parameters::default()
            },
        ];
        let mut plant =
            aem_model::Plant::new(Parameters::default(), &config, Some(&sets), 0.0, 12_000.0)
                .unwrap();
        for k in 0..400 {
            plant
                .step(
                    &config,
                    0.0,
                    0.0,
                    if k < 100 { 3_000.0 } else { 20_000.0 },
                    1.0,
                )
                .unwrap();
        }
        let inputs = Inputs {
            setpoint: 0.0,
            power_reference: 20_000.0,
            frequency: 50.0,
            ambient_temperature: 300.0,
        };
        let file = "/data/params.json".to_string();
        SavedState::new(
            FmiState::StepComplete,
            Parameters::default(),
            settings,
            inputs,
            0.0,
            false,
            400.0,
            None,
            file,
            Some(sets),
            RESERVE,
            Some(plant.snapshot()),
        )
    }

    #[test]
    fn a_hub_round_trips_exactly() {
        let s = hub_sample();
        match &s.plant {
            Some(PlantSnapshot::Hub(h)) => assert!(
                h.groups.len() >= 2,
                "a sequential hub mid-start has several groups"
            ),
            _ => panic!("not a hub"),
        }
        assert_eq!(SavedState::deserialize(&s.serialize()), Ok(s));
    }

    #[test]
    fn round_trip_is_exact() {
        let s = sample();
        assert_eq!(SavedState::deserialize(&s.serialize()), Ok(s));
    }

    #[test]
    fn every_corruption_is_refused() {
        for bytes in [sample().serialize(), hub_sample().serialize()] {
            every_corruption_of(&bytes);
        }
    }

    fn every_corruption_of(bytes: &[u8]) {
        let bytes = bytes.to_vec();
        for i in 0..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0x5a;
            assert!(
                SavedState::deserialize(&b).is_err(),
                "flipped byte {i} accepted"
            );
        }
        for n in 0..bytes.len() {
            assert!(
                SavedState::deserialize(&bytes[..n]).is_err(),
                "truncated to {n} accepted"
            );
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(SavedState::deserialize(&longer).is_err());
    }
}
