//! FMU states for fmi2GetFMUstate/fmi2SetFMUstate and their serialised form.
//!
//! Serialised layout (little endian): magic "AEMFMUST", format version (u32), payload
//! length (u32), payload, CRC-32 of everything before it (u32). The payload holds the GUID
//! and every field of [`SavedState`]; on the way back in, magic, version, length, checksum,
//! GUID, enum codes and parameter validity are all checked.

use crate::model::{CurrentState, ModuleState, Parameters};
use crate::model_description::GUID;

use super::state_machine::FmiState;

const MAGIC: &[u8; 8] = b"AEMFMUST";
/// Version of the serialised format; bump it whenever the payload changes.
pub const FORMAT_VERSION: u32 = 3;
/// Number of Reals in the payload.
const REALS: usize = 21;
const SAVED_MAGIC: u64 = 0x4145_4d5f_5354_4154; // "AEM_STAT"

/// A complete copy of an instance's state.
#[derive(Clone, Debug, PartialEq)]
#[repr(C)]
pub struct SavedState {
    magic: u64,
    /// FMI state of the instance.
    pub fmi_state: FmiState,
    /// Parameters (they may differ from the start values).
    pub params: Parameters,
    /// Input value as last set [%].
    pub setpoint: f64,
    /// Its derivative for the next step [%/s].
    pub setpoint_slope: f64,
    /// Whether the setpoint is outside the window (a warning was logged).
    pub excursion: bool,
    /// Communication time [s].
    pub time: f64,
    /// stopTime of fmi2SetupExperiment, if defined [s].
    pub stop_time: Option<f64>,
    /// Module state, once initialised.
    pub module: Option<ModuleState>,
}

impl SavedState {
    /// A new saved state.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        fmi_state: FmiState,
        params: Parameters,
        setpoint: f64,
        setpoint_slope: f64,
        excursion: bool,
        time: f64,
        stop_time: Option<f64>,
        module: Option<ModuleState>,
    ) -> Self {
        SavedState { magic: SAVED_MAGIC, fmi_state, params, setpoint, setpoint_slope, excursion, time, stop_time, module }
    }

    /// Whether `ptr` is aligned and its memory carries a saved state's magic (a cheap guard
    /// against foreign pointers; reads only the magic word, as raw bytes).
    ///
    /// # Safety
    /// `ptr` must be non-null and point to at least `size_of::<SavedState>()` readable bytes.
    pub unsafe fn has_magic(ptr: *const SavedState) -> bool {
        ptr.is_aligned() && unsafe { std::ptr::addr_of!((*ptr).magic).read_unaligned() } == SAVED_MAGIC
    }

    /// Marks the memory as no longer a state, just before it is freed.
    pub fn invalidate(&mut self) {
        self.magic = 0;
    }

    fn reals(&self) -> [f64; REALS] {
        let p = &self.params;
        let m = self.module.unwrap_or(ModuleState {
            time: 0.0,
            current: CurrentState { z1: 0.0, z2: 0.0, current: 0.0 },
            energy: 0.0,
            h2_produced: 0.0,
        });
        [
            self.setpoint,
            self.time,
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
            m.time,
            m.current.z1,
            m.current.z2,
            m.current.current,
            m.energy,
            m.h2_produced,
            self.setpoint_slope,
            self.stop_time.unwrap_or(0.0),
        ]
    }

    /// The serialised bytes.
    pub fn serialize(&self) -> Vec<u8> {
        let mut payload = Vec::with_capacity(256);
        payload.extend_from_slice(&(GUID.len() as u32).to_le_bytes());
        payload.extend_from_slice(GUID.as_bytes());
        payload.push(self.fmi_state.code());
        payload.push(self.excursion as u8);
        payload.push(self.module.is_some() as u8);
        payload.push(self.stop_time.is_some() as u8);
        for x in self.reals() {
            payload.extend_from_slice(&x.to_le_bytes());
        }
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
    pub fn deserialize(bytes: &[u8]) -> Result<SavedState, String> {
        let mut r = Reader { bytes, pos: 0 };
        if r.take(8)? != MAGIC {
            return Err("not a serialised state of this FMU (bad magic)".into());
        }
        let version = r.u32()?;
        if version != FORMAT_VERSION {
            return Err(format!("serialised state has format version {version}; this FMU reads version {FORMAT_VERSION}"));
        }
        let len = r.u32()? as usize;
        if bytes.len() != 16 + len + 4 {
            return Err(format!("serialised state is {} bytes; its header announces {}", bytes.len(), 16 + len + 4));
        }
        let crc = u32::from_le_bytes(bytes[16 + len..].try_into().map_err(|_| "truncated checksum")?);
        if crc != crc32fast::hash(&bytes[..16 + len]) {
            return Err("serialised state is corrupt (checksum mismatch)".into());
        }
        let guid_len = r.u32()? as usize;
        if r.take(guid_len)? != GUID.as_bytes() {
            return Err(format!("serialised state belongs to another model (GUID differs from {GUID})"));
        }
        let fmi_state = FmiState::from_code(r.u8()?).ok_or("serialised state has an unknown FMI state")?;
        let excursion = r.flag()?;
        let has_module = r.flag()?;
        let has_stop = r.flag()?;
        let mut x = [0.0; REALS];
        for v in x.iter_mut() {
            *v = r.f64()?;
        }
        if let Some(bad) = x.iter().position(|v| !v.is_finite()) {
            return Err(format!("serialised state holds a non-finite value at position {bad}"));
        }
        let params = Parameters {
            gain: x[2],
            tau_zero: x[3],
            tau_pole1: x[4],
            tau_pole2: x[5],
            ramp_up_limit: x[6],
            voltage_intercept: x[7],
            ohmic_resistance: x[8],
            h2_coefficient: x[9],
            nominal_current: x[10],
            min_setpoint: x[11],
            max_setpoint: x[12],
        };
        let module = has_module.then_some(ModuleState {
            time: x[13],
            current: CurrentState { z1: x[14], z2: x[15], current: x[16] },
            energy: x[17],
            h2_produced: x[18],
        });
        if module.is_some() {
            params.validate().map_err(|e| format!("serialised state holds invalid parameters: {e}"))?;
        }
        Ok(SavedState::new(fmi_state, params, x[0], x[19], excursion, x[1], has_stop.then_some(x[20]), module))
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.pos.checked_add(n).filter(|e| *e <= self.bytes.len()).ok_or("serialised state is truncated")?;
        let slice = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(slice)
    }
    fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    fn flag(&mut self) -> Result<bool, String> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            other => Err(format!("serialised state has an invalid flag {other}")),
        }
    }
    fn u32(&mut self) -> Result<u32, String> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn f64(&mut self) -> Result<f64, String> {
        let b = self.take(8)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(f64::from_le_bytes(a))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> SavedState {
        let module = ModuleState {
            time: 12.5,
            current: CurrentState { z1: 40.0, z2: 38.5, current: 39.25 },
            energy: 1.0e6,
            h2_produced: 33.0,
        };
        SavedState::new(FmiState::StepComplete, Parameters::default(), 73.0, -0.25, false, 112.5, Some(3600.0), Some(module))
    }

    #[test]
    fn round_trip_is_exact() {
        let s = sample();
        assert_eq!(SavedState::deserialize(&s.serialize()), Ok(s));
    }

    #[test]
    fn every_corruption_is_refused() {
        let bytes = sample().serialize();
        for i in 0..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0x5a;
            assert!(SavedState::deserialize(&b).is_err(), "flipped byte {i} accepted");
        }
        for n in 0..bytes.len() {
            assert!(SavedState::deserialize(&bytes[..n]).is_err(), "truncated to {n} accepted");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(SavedState::deserialize(&longer).is_err());
    }
}
