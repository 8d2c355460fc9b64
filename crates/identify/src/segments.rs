//! Running segments and setpoint steps, as in the paper's §III-C.
//!
//! A running segment is a stretch of consecutive rows of one gap-free block in which the
//! module runs (current above [`StepOptions::running_current`] and setpoint above 0):
//! start-ups begin one, shut-downs and trips end one. Inside a segment the setpoint is
//! piecewise constant; a level ends where the setpoint leaves its first value by more than
//! [`StepOptions::level_tolerance`].
//!
//! Timing convention: row n's setpoint is taken to act from row n − 1 on (the first sample
//! after a change already carries response), so a step is timed from the sample before the
//! first row with the new setpoint, and the model is stepped from t[n−1] to t[n] with u[n].

use std::ops::Range;
use std::path::PathBuf;

use super::columns::Channel;
use super::read::ModuleLog;

/// Settings of segmentation and step selection.
#[derive(Clone, Debug)]
pub struct StepOptions {
    /// A row is running when its current exceeds this [A] (and its setpoint exceeds 0).
    pub running_current: f64,
    /// Rows within this time after a segment starts (start-up, or after a gap) are not
    /// steady running [s]; five times the slow pole lets its transient decay below 1 %.
    pub settle: f64,
    /// A setpoint change larger than this starts a new level [%].
    pub level_tolerance: f64,
    /// Smallest step used for fitting [%].
    pub min_step: f64,
    /// Length of the pre-step window whose mean is subtracted [s].
    pub pre_window: f64,
    /// Shortest response (time to the next change) used for fitting [s].
    pub min_response: f64,
    /// Operating window of the setpoint [%]: steps from or to outside it are excluded.
    pub setpoint_window: (f64, f64),
}

impl Default for StepOptions {
    fn default() -> Self {
        let window = aem_model::Parameters::default();
        StepOptions {
            running_current: 1.0,
            settle: 600.0,
            level_tolerance: 0.5,
            min_step: 1.0,
            pre_window: 60.0,
            min_response: 60.0,
            setpoint_window: (window.min_setpoint, window.max_setpoint),
        }
    }
}

/// Consecutive running rows: time [s], setpoint [%], current [A].
#[derive(Clone, Debug)]
pub struct Segment {
    /// File of the rows.
    pub source: PathBuf,
    /// Time [s], strictly increasing.
    pub time: Vec<f64>,
    /// Setpoint [%].
    pub setpoint: Vec<f64>,
    /// Measured current [A].
    pub current: Vec<f64>,
}

impl Segment {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// True without rows.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }
}

/// Direction of a setpoint step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Sign {
    /// Setpoint and current fall; no rate limit acts.
    Negative,
    /// Setpoint rises; the rising-current limit may act.
    Positive,
}

impl Sign {
    /// "negative" or "positive".
    pub const fn label(self) -> &'static str {
        match self {
            Sign::Negative => "negative",
            Sign::Positive => "positive",
        }
    }
}

/// One setpoint step during steady running and its response window.
#[derive(Clone, Debug)]
pub struct Step {
    /// Index of the segment.
    pub segment: usize,
    /// Row of the sample before the first row with the new setpoint (time zero of the step).
    pub before: usize,
    /// Rows of the pre-step window (ends with `before`).
    pub pre: Range<usize>,
    /// Rows of the response, from the first row with the new setpoint to the next change.
    pub post: Range<usize>,
    /// Setpoint before [%].
    pub from: f64,
    /// Setpoint after [%].
    pub to: f64,
    /// Mean measured current over the pre-step window [A].
    pub pre_mean: f64,
}

impl Step {
    /// Step size to − from [%].
    pub fn size(&self) -> f64 {
        self.to - self.from
    }

    /// Direction.
    pub fn sign(&self) -> Sign {
        if self.to < self.from {
            Sign::Negative
        } else {
            Sign::Positive
        }
    }

    /// Group of steps of the same sign and size rounded to a whole percent.
    pub fn group(&self) -> (Sign, i64) {
        (self.sign(), self.size().abs().round() as i64)
    }
}

/// Steps found and why the others were left out.
#[derive(Clone, Debug, Default)]
pub struct StepSet {
    /// Running segments.
    pub segments: Vec<Segment>,
    /// Steps during steady running that qualify for fitting.
    pub steps: Vec<Step>,
    /// Setpoint changes in total (including start-ups' and shut-downs' neighbours).
    pub changes: usize,
    /// Left out: the pre-step window starts within the settle time after a start-up or gap.
    pub after_start: usize,
    /// Left out: from or to a setpoint outside the operating window (e.g. shut-down commands).
    pub outside_window: usize,
    /// Left out: smaller than the minimum step.
    pub too_small: usize,
    /// Left out: the preceding level is shorter than the pre-step window.
    pub short_level: usize,
    /// Left out: the response lasts less than the minimum response.
    pub short_response: usize,
}

/// Running segments of a module's log (needs setpoint and current).
pub fn running_segments(log: &ModuleLog, options: &StepOptions) -> Vec<Segment> {
    let mut segments = Vec::new();
    for block in &log.blocks {
        let (Some(setpoint), Some(current)) = (
            block.channel(Channel::Setpoint),
            block.channel(Channel::Current),
        ) else {
            continue;
        };
        let mut start = None;
        for i in 0..=block.len() {
            let running =
                i < block.len() && current[i] > options.running_current && setpoint[i] > 0.0;
            match (running, start) {
                (true, None) => start = Some(i),
                (false, Some(s)) => {
                    if i - s >= 2 {
                        segments.push(Segment {
                            source: block.source.clone(),
                            time: block.time[s..i].to_vec(),
                            setpoint: setpoint[s..i].to_vec(),
                            current: current[s..i].to_vec(),
                        });
                    }
                    start = None;
                }
                _ => {}
            }
        }
    }
    segments
}

/// Finds the setpoint steps of every segment and selects those during steady running.
pub fn find_steps(segments: Vec<Segment>, options: &StepOptions) -> StepSet {
    let mut set = StepSet::default();
    let (lo, hi) = options.setpoint_window;
    let inside = |u: f64| u >= lo - 1e-9 && u <= hi + 1e-9;
    for (index, seg) in segments.iter().enumerate() {
        let t = &seg.time;
        let u = &seg.setpoint;
        // First row of every level.
        let mut starts = vec![0usize];
        for n in 1..seg.len() {
            let level_start = starts[starts.len() - 1];
            if (u[n] - u[level_start]).abs() > options.level_tolerance {
                starts.push(n);
            }
        }
        starts.push(seg.len());
        for w in 1..starts.len() - 1 {
            set.changes += 1;
            let (p, n, e) = (starts[w - 1], starts[w], starts[w + 1]);
            let (from, to) = (u[p], u[n]);
            let t0 = t[n - 1];
            if !(inside(from) && inside(to)) {
                set.outside_window += 1;
                continue;
            }
            if (to - from).abs() < options.min_step {
                set.too_small += 1;
                continue;
            }
            if t0 - t[p] < options.pre_window {
                set.short_level += 1;
                continue;
            }
            if t0 - options.pre_window < t[0] + options.settle {
                set.after_start += 1;
                continue;
            }
            if t[e - 1] - t0 < options.min_response {
                set.short_response += 1;
                continue;
            }
            let pre_start = p + t[p..n].partition_point(|&ti| ti < t0 - options.pre_window);
            let pre = pre_start..n;
            let pre_mean = seg.current[pre.clone()].iter().sum::<f64>() / pre.len() as f64;
            set.steps.push(Step {
                segment: index,
                before: n - 1,
                pre,
                post: n..e,
                from,
                to,
                pre_mean,
            });
        }
    }
    set.segments = segments;
    set
}
