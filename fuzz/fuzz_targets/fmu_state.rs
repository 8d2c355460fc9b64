//! fmi2DeSerializeFMUstate with any bytes, through the FMU's C ABI, on a live instance; a state
//! that is accepted is then set and stepped. Inputs whose first byte is odd get the envelope
//! of a real state around the rest (magic, format version, length, CRC-32), so the fuzzer
//! reaches the payload's parser instead of stopping at the checksum.
#![no_main]

use std::ptr::{null, null_mut};

use aem_electrolyser::fmi2::exports::*;
use aem_electrolyser::fmi2::fmu_state::{FORMAT_VERSION, MAGIC};
use aem_electrolyser::model_description::GUID;
use fmi_sys::fmi2 as sys;
use libfuzzer_sys::fuzz_target;

fn enveloped(payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(payload.len() + 20);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(payload);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

fuzz_target!(|data: &[u8]| {
    let bytes = match data.split_first() {
        Some((flag, rest)) if flag & 1 == 1 => enveloped(rest),
        Some((_, rest)) => rest.to_vec(),
        None => Vec::new(),
    };
    let callbacks = sys::fmi2CallbackFunctions {
        logger: None,
        allocateMemory: None,
        freeMemory: None,
        stepFinished: None,
        componentEnvironment: null_mut(),
    };
    let guid = std::ffi::CString::new(GUID).unwrap();
    unsafe {
        let c = fmi2Instantiate(
            c"fuzz".as_ptr(),
            sys::fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            null(),
            &callbacks,
            0,
            0,
        );
        assert!(!c.is_null());
        fmi2EnterInitializationMode(c);
        fmi2ExitInitializationMode(c);
        let mut state: sys::fmi2FMUstate = null_mut();
        let status = fmi2DeSerializeFMUstate(
            c,
            bytes.as_ptr() as *const sys::fmi2Byte,
            bytes.len(),
            &mut state,
        );
        if status == sys::fmi2Status_fmi2OK {
            assert!(!state.is_null());
            if fmi2SetFMUstate(c, state) == sys::fmi2Status_fmi2OK {
                // Step from wherever the state is, and read every Real output.
                let mut time = 0.0;
                fmi2GetRealStatus(c, sys::fmi2StatusKind_fmi2LastSuccessfulTime, &mut time);
                fmi2DoStep(c, time, 1.0, 1);
                let refs: Vec<u32> = (0..32).collect();
                let mut values = [0.0; 32];
                fmi2GetReal(c, refs.as_ptr(), 1, values.as_mut_ptr());
            }
            fmi2FreeFMUstate(c, &mut state);
        } else {
            assert!(state.is_null(), "a refused state must not be handed out");
        }
        fmi2FreeInstance(c);
    }
});
