//! The channels a log can carry and how a user's column names map onto them.

use std::fmt;

/// Numeric channels besides time ([`Channel::MEASURED`]).
pub const MEASURED_CHANNELS: usize = 7;

/// One measured channel of an operational log, with its unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Channel {
    /// Time: seconds (any origin) or RFC 3339 timestamps [s].
    Time,
    /// Hydrogen-production setpoint [%].
    Setpoint,
    /// Stack current [A].
    Current,
    /// Stack voltage [V].
    Voltage,
    /// Electrolyte temperature [°C].
    Temperature,
    /// Stack (hydrogen) pressure [bar].
    Pressure,
    /// Hydrogen flow [Nl/h].
    H2Flow,
    /// Ambient (air) temperature around the stack [°C].
    Ambient,
    /// Module identifier (text), when one file holds several modules.
    Module,
}

impl Channel {
    /// Every channel, in the order of the input format.
    pub const ALL: [Channel; 9] = [
        Channel::Time,
        Channel::Setpoint,
        Channel::Current,
        Channel::Voltage,
        Channel::Temperature,
        Channel::Pressure,
        Channel::H2Flow,
        Channel::Ambient,
        Channel::Module,
    ];

    /// The numeric channels besides time, in storage order (see [`Channel::index`]).
    pub const MEASURED: [Channel; MEASURED_CHANNELS] = [
        Channel::Setpoint,
        Channel::Current,
        Channel::Voltage,
        Channel::Temperature,
        Channel::Pressure,
        Channel::H2Flow,
        Channel::Ambient,
    ];

    /// Default column name, also the key of `--column KEY=NAME`.
    pub const fn key(self) -> &'static str {
        match self {
            Channel::Time => "time",
            Channel::Setpoint => "setpoint",
            Channel::Current => "current",
            Channel::Voltage => "voltage",
            Channel::Temperature => "temperature",
            Channel::Pressure => "pressure",
            Channel::H2Flow => "h2_flow",
            Channel::Ambient => "ambient_temperature",
            Channel::Module => "module",
        }
    }

    /// Unit of the channel's values.
    pub const fn unit(self) -> &'static str {
        match self {
            Channel::Time => "s or RFC 3339",
            Channel::Setpoint => "%",
            Channel::Current => "A",
            Channel::Voltage => "V",
            Channel::Temperature => "°C",
            Channel::Pressure => "bar",
            Channel::H2Flow => "Nl/h",
            Channel::Ambient => "°C",
            Channel::Module => "text",
        }
    }

    /// Position among [`Channel::MEASURED`], for the numeric channels besides time.
    pub const fn index(self) -> Option<usize> {
        match self {
            Channel::Setpoint => Some(0),
            Channel::Current => Some(1),
            Channel::Voltage => Some(2),
            Channel::Temperature => Some(3),
            Channel::Pressure => Some(4),
            Channel::H2Flow => Some(5),
            Channel::Ambient => Some(6),
            Channel::Time | Channel::Module => None,
        }
    }

    /// The channel with this key.
    pub fn from_key(key: &str) -> Option<Channel> {
        Channel::ALL.into_iter().find(|c| c.key() == key)
    }
}

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.key())
    }
}

/// Column name of each channel in the user's files.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ColumnMap {
    names: [String; 9],
}

impl Default for ColumnMap {
    /// Every channel under its default name ([`Channel::key`]).
    fn default() -> Self {
        ColumnMap {
            names: Channel::ALL.map(|c| c.key().to_string()),
        }
    }
}

impl ColumnMap {
    /// The default names with `KEY=NAME` mappings applied, e.g. `current=StackCurrent`.
    pub fn with_mappings<S: AsRef<str>>(mappings: &[S]) -> Result<ColumnMap, String> {
        let mut map = ColumnMap::default();
        for m in mappings {
            let m = m.as_ref();
            let (key, name) = m.split_once('=').ok_or_else(|| {
                format!("column mapping `{m}` must look like KEY=NAME, e.g. current=StackCurrent")
            })?;
            let channel = Channel::from_key(key.trim()).ok_or_else(|| {
                let keys: Vec<&str> = Channel::ALL.iter().map(|c| c.key()).collect();
                format!(
                    "column mapping `{m}`: unknown key `{key}` (known: {})",
                    keys.join(", ")
                )
            })?;
            let name = name.trim();
            if name.is_empty() {
                return Err(format!("column mapping `{m}`: the column name is empty"));
            }
            map.set(channel, name);
        }
        Ok(map)
    }

    /// Maps `channel` to the column `name`.
    pub fn set(&mut self, channel: Channel, name: &str) {
        self.names[channel as usize] = name.to_string();
    }

    /// Column name of `channel`.
    pub fn name(&self, channel: Channel) -> &str {
        &self.names[channel as usize]
    }

    /// Index of each channel's column in `header` (exact match first, then ignoring case).
    pub fn locate(&self, header: &[&str]) -> [Option<usize>; 9] {
        Channel::ALL.map(|c| {
            let want = self.name(c);
            header.iter().position(|h| h.trim() == want).or_else(|| {
                header
                    .iter()
                    .position(|h| h.trim().eq_ignore_ascii_case(want))
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mappings_rename_and_unknown_keys_are_refused() {
        let map = ColumnMap::with_mappings(&["current=StackCurrent", " h2_flow = H2 "]).unwrap();
        assert_eq!(map.name(Channel::Current), "StackCurrent");
        assert_eq!(map.name(Channel::H2Flow), "H2");
        assert_eq!(map.name(Channel::Voltage), "voltage");
        assert!(ColumnMap::with_mappings(&["amps=I"])
            .unwrap_err()
            .contains("unknown key `amps`"));
        assert!(ColumnMap::with_mappings(&["current"])
            .unwrap_err()
            .contains("KEY=NAME"));
        assert!(ColumnMap::with_mappings(&["current="])
            .unwrap_err()
            .contains("empty"));
    }

    #[test]
    fn columns_are_found_exactly_then_ignoring_case() {
        let map = ColumnMap::with_mappings(&["current=I_stack"]).unwrap();
        let idx = map.locate(&["Time", "I_stack", "setpoint", "i_stack"]);
        assert_eq!(idx[Channel::Time as usize], Some(0));
        assert_eq!(idx[Channel::Current as usize], Some(1));
        assert_eq!(idx[Channel::Setpoint as usize], Some(2));
        assert_eq!(idx[Channel::Voltage as usize], None);
    }
}
