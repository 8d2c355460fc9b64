//! Stack-current dynamics, integrated exactly.
//!
//! Linear part (paper eq. 1), setpoint u [%] to unlimited current I_tf [A]:
//!   G(s) = K(τz s + 1) / ((τp1 s + 1)(τp2 s + 1))
//!        = K·a/(τp1 s + 1) + K·b/(τp2 s + 1),
//!   a = (τz − τp1)/(τp2 − τp1),  b = (τp2 − τz)/(τp2 − τp1) = 1 − a
//!   (computed in one place, [`Parameters::modal_weights`]).
//! Modal states z1, z2 [A]: τpi·dzi/dt = K·u − zi, and I_tf = a·z1 + b·z2.
//!
//! Rising-rate limit r [A/s] on the output, none on falling current:
//!   I(t) = min( I(t0) + r(t − t0),  min_{s∈[t0,t]} I_tf(s) + r(t − s) ).
//! With h(s) = I_tf(s) − r·s this is I(t) = r·t + min(I(t0) − r·t0, min_{[t0,t]} h): the
//! current is r·t plus the running minimum of h. With u constant over a step, h is a constant
//! plus two exponentials minus a line, so h has at most two stationary points, found by
//! splitting the step where h'' and h' change sign. On each monotone piece the running
//! minimum either stays put (current ramps at r) or follows h (current tracks I_tf); the
//! instant where it switches is located by a bracketed root search. Everything else is
//! closed form, so results at common time points do not depend on the step size.
//!
//! Reserve control (optional): the setpoint is pre-filtered by F(s) = (τn s + 1)/(τz s + 1),
//! which moves the zero of the transfer function from τz to τn:
//!   G(s)·F(s) = K(τn s + 1)/((τp1 s + 1)(τp2 s + 1)) = K·a'/(τp1 s + 1) + K·b'/(τp2 s + 1),
//!   a' = (τn − τp1)/(τp2 − τp1),  b' = 1 − a'.
//! τn = τz is the paper's model (plain droop); τn = τp2 cancels the slow pole
//! ([`CurrentDynamics::with_compensation`]: G·F = K/(τp1 s + 1), the fast pole alone);
//! any τn in [τp1, τp2] ([`CurrentDynamics::with_filter_zero`]) lies between them. In modal
//! form mode i is driven by K·u·ri with r1 = a'/a, r2 = b'/b (τpi·dzi/dt = K·u·ri − zi;
//! I_tf = a·z1 + b·z2 as ever). For u held over a step this is the plain step in shifted
//! states zi' = zi + K·u·(1 − ri) (a·(1 − r1) + b·(1 − r2) = 1 − a' − b' = 0, so I_tf is
//! unchanged): the same exact step, rate limit included. With τn in [τp1, τp2] both weights
//! a', b' are ≥ 0, so the step response is monotone: a setpoint inside the window keeps the
//! current inside it.

use super::parameters::Parameters;
use super::roots::monotone_root;
use super::select::at_least;

/// Dynamic state of the current: modal states and the limited current, all [A].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CurrentState {
    /// Fast modal state z1 (pole τp1) [A].
    pub z1: f64,
    /// Slow modal state z2 (pole τp2) [A].
    pub z2: f64,
    /// Rate-limited stack current I ≤ I_tf [A].
    pub current: f64,
}

/// Time integrals of the current over one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CurrentIntegrals {
    /// ∫ I dt [A·s].
    pub charge: f64,
    /// ∫ I² dt [A²·s].
    pub current_squared: f64,
    /// Time during which the rate limit was binding [s].
    pub ramp_time: f64,
    /// ∫τ·I dτ over the step, τ from its start [A·s²] (only from [`CurrentDynamics::advance_with_moments`]).
    pub time_moment: f64,
    /// ∫e^(−μτ)·I dτ over the step [A·s] (only from [`CurrentDynamics::advance_with_moments`]).
    pub decay_moment: f64,
}

/// The current over one step where it is known in closed form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Envelope {
    /// Its smallest and largest value [A].
    pub min: f64,
    pub max: f64,
    /// ∫I dt [A·s] and ∫I² dt [A²·s] over the step.
    pub charge: f64,
    pub current_squared: f64,
}

/// Constants of the current dynamics, derived once from the parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentDynamics {
    gain: f64,
    tau1: f64,
    tau2: f64,
    lambda1: f64,
    lambda2: f64,
    a: f64,
    b: f64,
    ramp: f64,
    /// Weights of the closed-form integrals over a tracking segment (see [`Decay`]):
    /// a·τp1, b·τp2 [s]; a²·τp1/2, b²·τp2/2, 2ab/(λ1 + λ2) [s].
    k1: f64,
    k2: f64,
    k11: f64,
    k22: f64,
    k12: f64,
    /// The setpoint's pre-filter (the reserve control).
    filter: SetpointFilter,
}

/// The setpoint's pre-filter F(s) = (τn s + 1)/(τz s + 1) (see the module's doc).
#[derive(Clone, Copy, Debug, PartialEq)]
enum SetpointFilter {
    /// F = 1 (τn = τz): the paper's model.
    None,
    /// τn = τp2: the slow pole cancelled.
    CancelSlowPole,
    /// Any other τn in [τp1, τp2]: the modes' drive ratios r1 = a'/a, r2 = b'/b.
    Zero { r1: f64, r2: f64 },
}

/// What [`CurrentDynamics::advance_with_moments`] was last asked: the dynamics and the bits of
/// the start state, setpoint, step and rate.
#[derive(Clone, Copy, Debug, PartialEq)]
struct MomentsKey {
    dynamics: CurrentDynamics,
    start: [u64; 6],
}

thread_local! {
    /// The last step with moments on this thread: its key, end state and integrals.
    static LAST_MOMENTS: std::cell::Cell<Option<(MomentsKey, CurrentState, CurrentIntegrals)>> =
        const { std::cell::Cell::new(None) };
}

/// Decay of both modes over one interval of length L: e^(−λi L) and 1 − e^(−λi L)
/// (from expm1, so short intervals keep full precision), and 1 − e^(−(λ1+λ2) L).
#[derive(Clone, Copy, Debug)]
struct Decay {
    e1: f64,
    e2: f64,
    d1: f64,
    d2: f64,
    d12: f64,
}

/// Step-size dependent factors, reused while the master keeps its step size.
#[derive(Clone, Copy, Debug)]
pub struct StepFactors {
    h: f64,
    decay: Decay,
    tracking: TrackingStep,
}

impl Default for StepFactors {
    fn default() -> Self {
        // NaN never compares equal, so the first step always computes its factors.
        let tracking = TrackingStep {
            h: f64::NAN,
            ..TrackingStep::ZERO
        };
        StepFactors {
            h: f64::NAN,
            decay: Decay {
                e1: 1.0,
                e2: 1.0,
                d1: 0.0,
                d2: 0.0,
                d12: 0.0,
            },
            tracking,
        }
    }
}

/// Weights of the closed-form integrals over a tracking segment with decay `Decay`
/// (see [`CurrentDynamics::track_integrals`]): ∫I_tf = yL + w1 δ1 + w2 δ2 and
/// ∫I_tf² = y²L + 2y(w1 δ1 + w2 δ2) + q11 δ1² + q22 δ2² + q12 δ1 δ2, all [s].
#[derive(Clone, Copy, Debug)]
struct Weights {
    w1: f64,
    w2: f64,
    q11: f64,
    q22: f64,
    q12: f64,
}

/// One exact step of fixed length h at a constant setpoint in the common case: the current
/// tracks I_tf at the start and I_tf cannot rise faster than the ramp limit during the step
/// (its largest slope, Σ max(−λi·ci·δi, 0), is at most r), so I = I_tf throughout. Branch-free,
/// so that the scalar path and the four-lane kernel ([`super::lanes`]) run the same arithmetic
/// and give bit-identical results.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackingStep {
    /// K [A/%].
    pub gain: f64,
    /// Modal weights a, b of I_tf = a·z1 + b·z2.
    pub a: f64,
    pub b: f64,
    /// e^(−λi h).
    pub e1: f64,
    pub e2: f64,
    /// Integral weights at h [s] (see [`Weights`]).
    pub w1: f64,
    pub w2: f64,
    pub q11: f64,
    pub q22: f64,
    pub q12: f64,
    /// −λ1·a, −λ2·b [1/s]: I_tf's initial slope per unit of modal deviation.
    pub rise1: f64,
    pub rise2: f64,
    /// Ramp limit r [A/s].
    pub ramp: f64,
    /// Step length h [s].
    pub h: f64,
}

/// The outcome of [`TrackingStep::step`]; meaningful only where `tracks` holds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrackedStep {
    /// The state at the end of the step.
    pub state: CurrentState,
    /// ∫I dt [A·s].
    pub charge: f64,
    /// ∫I² dt [A²·s].
    pub current_squared: f64,
    /// The step was in the common case (the other fields are the exact result).
    pub tracks: bool,
}

impl TrackingStep {
    /// All zero (the placeholder before a step length is known).
    pub const ZERO: TrackingStep = TrackingStep {
        gain: 0.0,
        a: 0.0,
        b: 0.0,
        e1: 0.0,
        e2: 0.0,
        w1: 0.0,
        w2: 0.0,
        q11: 0.0,
        q22: 0.0,
        q12: 0.0,
        rise1: 0.0,
        rise2: 0.0,
        ramp: 0.0,
        h: 0.0,
    };

    /// The step from `state` with setpoint `u` [%] (already clamped) held for h:
    ///   δi = zi − K u,  zi ← K u + δi e^(−λi h),  I ← a z1 + b z2,
    ///   ∫I = K u h + w1 δ1 + w2 δ2,  ∫I² = (K u)² h + 2 K u (w1 δ1 + w2 δ2) + q11 δ1² + q22 δ2² + q12 δ1 δ2.
    #[inline(always)]
    pub fn step(&self, state: &CurrentState, u: f64) -> TrackedStep {
        let base = self.gain * u;
        let (dev1, dev2) = (state.z1 - base, state.z2 - base);
        let tf0 = base + self.a * dev1 + self.b * dev2;
        let at_tf = tf0 - state.current <= 1e-12 * at_least(tf0.abs(), 1.0);
        let max_rise = at_least(self.rise1 * dev1, 0.0) + at_least(self.rise2 * dev2, 0.0);
        let z1 = base + dev1 * self.e1;
        let z2 = base + dev2 * self.e2;
        let lin = self.w1 * dev1 + self.w2 * dev2;
        TrackedStep {
            state: CurrentState {
                z1,
                z2,
                current: self.a * z1 + self.b * z2,
            },
            charge: base * self.h + lin,
            current_squared: base * base * self.h
                + 2.0 * base * lin
                + self.q11 * dev1 * dev1
                + self.q22 * dev2 * dev2
                + self.q12 * dev1 * dev2,
            tracks: at_tf & (max_rise <= self.ramp),
        }
    }
}

impl CurrentDynamics {
    /// Derives the modal constants; `params` must have passed [`Parameters::validate`].
    pub fn new(params: &Parameters) -> Self {
        let (t1, t2) = (params.tau_pole1, params.tau_pole2);
        let (a, b) = params.modal_weights();
        let (lambda1, lambda2) = (1.0 / t1, 1.0 / t2);
        CurrentDynamics {
            gain: params.gain,
            tau1: t1,
            tau2: t2,
            lambda1,
            lambda2,
            a,
            b,
            ramp: params.ramp_up_limit,
            k1: a * t1,
            k2: b * t2,
            k11: 0.5 * a * a * t1,
            k22: 0.5 * b * b * t2,
            k12: 2.0 * a * b / (lambda1 + lambda2),
            filter: SetpointFilter::None,
        }
    }

    /// The same dynamics with reserve compensation on (the slow pole cancelled, τn = τp2) or
    /// off (the paper's model; see the module's doc).
    pub fn with_compensation(mut self, on: bool) -> Self {
        self.filter = if on {
            SetpointFilter::CancelSlowPole
        } else {
            SetpointFilter::None
        };
        self
    }

    /// The same dynamics with the setpoint pre-filter that puts the zero at `tau_n` [s], which
    /// must lie in [τp1, τp2] (the caller checks, [`Parameters::filter_zero_range`]); τz is the
    /// paper's model and τp2 [`Self::with_compensation`], bit for bit.
    pub fn with_filter_zero(mut self, tau_n: f64) -> Self {
        let (t1, t2) = (self.tau1, self.tau2);
        // a', b' as [`Parameters::modal_weights`] computes a, b: τn = τz gives them bit for bit.
        let (a_n, b_n) = ((tau_n - t1) / (t2 - t1), (t2 - tau_n) / (t2 - t1));
        self.filter = if tau_n == t2 {
            SetpointFilter::CancelSlowPole
        } else if a_n == self.a && b_n == self.b {
            SetpointFilter::None
        } else {
            SetpointFilter::Zero {
                r1: a_n / self.a,
                r2: b_n / self.b,
            }
        };
        self
    }

    /// Whether the setpoint is pre-filtered (the dynamics then take held setpoints only).
    pub fn is_compensated(&self) -> bool {
        self.filter != SetpointFilter::None
    }

    /// Steady state at a (clamped) setpoint [%]: z1 = z2 = I = K·u; pre-filtered zi = K·u·ri
    /// (slow pole cancelled: z1 = K·u/a, z2 = 0), I = K·u all the same.
    pub fn steady_state(&self, setpoint: f64) -> CurrentState {
        let y = self.gain * setpoint;
        match self.filter {
            SetpointFilter::None => CurrentState {
                z1: y,
                z2: y,
                current: y,
            },
            SetpointFilter::CancelSlowPole => CurrentState {
                z1: y / self.a,
                z2: 0.0,
                current: y,
            },
            SetpointFilter::Zero { r1, r2 } => CurrentState {
                z1: y * r1,
                z2: y * r2,
                current: y,
            },
        }
    }

    /// The shift K·u·(1 − ri) of each modal state that turns the pre-filtered step at held
    /// setpoint `u` [%] into the plain one (None without a filter).
    fn filter_shift(&self, u: f64) -> Option<(f64, f64)> {
        match self.filter {
            SetpointFilter::None => None,
            SetpointFilter::CancelSlowPole => {
                Some((-self.gain * u * self.b / self.a, self.gain * u))
            }
            SetpointFilter::Zero { r1, r2 } => {
                let y = self.gain * u;
                Some((y * (1.0 - r1), y * (1.0 - r2)))
            }
        }
    }

    /// Unlimited transfer-function output I_tf = a·z1 + b·z2 [A].
    pub fn unlimited_current(&self, state: &CurrentState) -> f64 {
        self.a * state.z1 + self.b * state.z2
    }

    fn decay(&self, length: f64) -> Decay {
        let m1 = (-self.lambda1 * length).exp_m1();
        let m2 = (-self.lambda2 * length).exp_m1();
        Decay {
            e1: 1.0 + m1,
            e2: 1.0 + m2,
            d1: -m1,
            d2: -m2,
            d12: -(m1 + m2 + m1 * m2),
        }
    }

    /// w1 = a τp1 (1 − e1), w2 = b τp2 (1 − e2), q11 = a²τp1/2 (1 − e1)(1 + e1),
    /// q22 = b²τp2/2 (1 − e2)(1 + e2), q12 = 2ab/(λ1 + λ2) (1 − e1 e2) [s].
    fn weights(&self, d: &Decay) -> Weights {
        Weights {
            w1: self.k1 * d.d1,
            w2: self.k2 * d.d2,
            q11: self.k11 * d.d1 * (1.0 + d.e1),
            q22: self.k22 * d.d2 * (1.0 + d.e2),
            q12: self.k12 * d.d12,
        }
    }

    /// The current over a step of `h` [s] from `state` with setpoint `u` [%] (clamped) held,
    /// where the step tracks (I = I_tf = K·u + A e^(−λ1 t) + B e^(−λ2 t) throughout, A = a·δ1,
    /// B = b·δ2): its extremes (the endpoints and the one stationary point, where
    /// A λ1 e^(−λ1 t) = −B λ2 e^(−λ2 t), if it lies inside) and its integrals. None where the
    /// rate limit may bind, and with compensation.
    pub fn tracking_envelope(&self, state: &CurrentState, u: f64, h: f64) -> Option<Envelope> {
        if self.is_compensated() || !(h > 0.0) {
            return None;
        }
        let step = self.tracking_step(h).step(state, u);
        if !step.tracks {
            return None;
        }
        let base = self.gain * u;
        let (big_a, big_b) = (self.a * (state.z1 - base), self.b * (state.z2 - base));
        let (start, end) = (state.current, step.state.current);
        let (mut lo, mut hi) = (start.min(end), start.max(end));
        let ratio = -(big_b * self.lambda2) / (big_a * self.lambda1);
        if ratio > 0.0 && ratio.is_finite() {
            let t = ratio.ln() / (self.lambda2 - self.lambda1);
            if t > 0.0 && t < h {
                let i =
                    base + big_a * (-self.lambda1 * t).exp() + big_b * (-self.lambda2 * t).exp();
                lo = lo.min(i);
                hi = hi.max(i);
            }
        }
        Some(Envelope {
            min: lo,
            max: hi,
            charge: step.charge,
            current_squared: step.current_squared,
        })
    }

    /// The current `t` [s] after `state` with setpoint `u` [%] (clamped) held, where it tracks
    /// from the start (then for good: I_tf's rising slopes only decay), in closed form
    /// K·u + a·δ1·e^(−λ1 t) + b·δ2·e^(−λ2 t); None where the rate limit may bind, and with
    /// compensation.
    #[inline]
    pub fn tracked_current(&self, state: &CurrentState, u: f64, t: f64) -> Option<f64> {
        if self.is_compensated() {
            return None;
        }
        let base = self.gain * u;
        let (dev1, dev2) = (state.z1 - base, state.z2 - base);
        let tf0 = base + self.a * dev1 + self.b * dev2;
        let at_tf = tf0 - state.current <= 1e-12 * at_least(tf0.abs(), 1.0);
        let max_rise = at_least(-self.lambda1 * self.a * dev1, 0.0)
            + at_least(-self.lambda2 * self.b * dev2, 0.0);
        (at_tf && max_rise <= self.ramp).then(|| {
            base + self.a * dev1 * (-self.lambda1 * t).exp()
                + self.b * dev2 * (-self.lambda2 * t).exp()
        })
    }

    /// The constants of a tracking step of length `h` [s].
    pub fn tracking_step(&self, h: f64) -> TrackingStep {
        self.tracking_from(h, &self.decay(h))
    }

    fn tracking_from(&self, h: f64, d: &Decay) -> TrackingStep {
        let w = self.weights(d);
        TrackingStep {
            gain: self.gain,
            a: self.a,
            b: self.b,
            e1: d.e1,
            e2: d.e2,
            w1: w.w1,
            w2: w.w2,
            q11: w.q11,
            q22: w.q22,
            q12: w.q12,
            rise1: -self.lambda1 * self.a,
            rise2: -self.lambda2 * self.b,
            ramp: self.ramp,
            h,
        }
    }

    /// ∫I dt and ∫I² dt over a tracking segment of length L on which
    /// I_tf(σ) = y + sσ + a δ1 e^(−λ1 σ) + b δ2 e^(−λ2 σ). With Δi = δi(1 − e^(−λi L)) and
    /// Ji = ∫₀ᴸ σ e^(−λi σ) dσ = τi² (1 − (1 + λi L) e^(−λi L)):
    ///   ∫I_tf  = y L + s L²/2 + a τp1 Δ1 + b τp2 Δ2
    ///   ∫I_tf² = ∫(y + sσ)² + 2y(a τp1 Δ1 + b τp2 Δ2) + 2s(a δ1 J1 + b δ2 J2)
    ///          + a² τp1/2 · Δ1(δ1 + δ1 e^(−λ1 L)) + b² τp2/2 · Δ2(δ2 + δ2 e^(−λ2 L))
    ///          + 2ab/(λ1+λ2) · δ1 δ2 (1 − e^(−(λ1+λ2) L))
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn track_integrals(
        &self,
        y: f64,
        s: f64,
        dev1: f64,
        dev2: f64,
        length: f64,
        decay: &Decay,
    ) -> (f64, f64) {
        let w = self.weights(decay);
        let lin = w.w1 * dev1 + w.w2 * dev2;
        let mut charge = y * length + lin;
        let mut squared = y * y * length
            + 2.0 * y * lin
            + w.q11 * dev1 * dev1
            + w.q22 * dev2 * dev2
            + w.q12 * dev1 * dev2;
        if s != 0.0 {
            let (l2, l3) = (length * length, length * length * length);
            let j1 = self.tau1 * self.tau1 * ramp_moment(self.lambda1 * length, decay.e1);
            let j2 = self.tau2 * self.tau2 * ramp_moment(self.lambda2 * length, decay.e2);
            charge += 0.5 * s * l2;
            squared +=
                y * s * l2 + s * s * l3 / 3.0 + 2.0 * s * (self.a * dev1 * j1 + self.b * dev2 * j2);
        }
        (charge, squared)
    }

    /// Advances `state` by `h` > 0 seconds with the setpoint `u` [%] held constant,
    /// returning the exact integrals of the current over the step.
    #[inline]
    pub fn advance(
        &self,
        state: &mut CurrentState,
        u: f64,
        h: f64,
        factors: &mut StepFactors,
    ) -> CurrentIntegrals {
        if let Some(shift) = self.filter_shift(u) {
            return self.shifted(state, shift, |plain, s| plain.advance(s, u, h, factors));
        }
        if factors.h != h {
            let decay = self.decay(h);
            *factors = StepFactors {
                h,
                decay,
                tracking: self.tracking_from(h, &decay),
            };
        }
        let fast = factors.tracking.step(state, u);
        if fast.tracks {
            *state = fast.state;
            return CurrentIntegrals {
                charge: fast.charge,
                current_squared: fast.current_squared,
                ..CurrentIntegrals::default()
            };
        }
        let decay = factors.decay;
        self.advance_segment(state, u, 0.0, h, &decay, None)
    }

    /// [`Self::advance`] with the current's moments over the step as well: ∫τ·I dτ and
    /// ∫e^(−μτ)·I dτ for a rate `mu` > 0 [1/s], in closed form on every ramp and tracking
    /// segment (what a voltage that drifts linearly and exponentially in time draws).
    ///
    /// The last call's inputs and result are kept per thread: a hub's groups that differ only
    /// in their drift are adjacent and step the same current, which is then computed once (a
    /// pure function's memo: the same inputs, bit for bit, give the same result).
    pub fn advance_with_moments(
        &self,
        state: &mut CurrentState,
        u: f64,
        h: f64,
        mu: f64,
    ) -> CurrentIntegrals {
        let key = MomentsKey {
            dynamics: *self,
            start: [state.z1, state.z2, state.current, u, h, mu].map(f64::to_bits),
        };
        if let Some((end, ints)) = LAST_MOMENTS.with(|last| {
            last.get()
                .filter(|(k, _, _)| *k == key)
                .map(|(_, end, ints)| (end, ints))
        }) {
            *state = end;
            return ints;
        }
        let ints = self.compute_with_moments(state, u, h, mu);
        LAST_MOMENTS.with(|last| last.set(Some((key, *state, ints))));
        ints
    }

    /// [`Self::advance_with_moments`] without the memo.
    fn compute_with_moments(
        &self,
        state: &mut CurrentState,
        u: f64,
        h: f64,
        mu: f64,
    ) -> CurrentIntegrals {
        if let Some(shift) = self.filter_shift(u) {
            return self.shifted(state, shift, |plain, s| {
                plain.compute_with_moments(s, u, h, mu)
            });
        }
        self.advance_segment(state, u, 0.0, h, &self.decay(h), Some(mu))
    }

    /// `step` of the plain dynamics in the modal states shifted by (c1, c2) (see the module's
    /// doc; I_tf is the same in both), the shift taken off again afterwards.
    #[inline]
    fn shifted(
        &self,
        state: &mut CurrentState,
        (c1, c2): (f64, f64),
        step: impl FnOnce(&CurrentDynamics, &mut CurrentState) -> CurrentIntegrals,
    ) -> CurrentIntegrals {
        state.z1 += c1;
        state.z2 += c2;
        let integrals = step(&self.plain(), state);
        state.z1 -= c1;
        state.z2 -= c2;
        integrals
    }

    /// The same dynamics without the pre-filter.
    fn plain(&self) -> CurrentDynamics {
        CurrentDynamics {
            filter: SetpointFilter::None,
            ..*self
        }
    }

    /// Advances `state` by `h` > 0 seconds with a setpoint that rises linearly from `u0` [%]
    /// at `slope` [%/s] (an interpolated input), returning the exact integrals. The caller
    /// keeps the setpoint inside the operating window over the step, and holds the setpoint of
    /// compensated dynamics (their plants take no slope).
    pub fn advance_linear(
        &self,
        state: &mut CurrentState,
        u0: f64,
        slope: f64,
        h: f64,
    ) -> CurrentIntegrals {
        debug_assert!(
            !self.is_compensated(),
            "compensated dynamics take held setpoints only"
        );
        self.advance_segment(state, u0, slope, h, &self.decay(h), None)
    }

    /// [`Self::advance_linear`] with the moments of [`Self::advance_with_moments`].
    pub fn advance_linear_with_moments(
        &self,
        state: &mut CurrentState,
        u0: f64,
        slope: f64,
        h: f64,
        mu: f64,
    ) -> CurrentIntegrals {
        debug_assert!(
            !self.is_compensated(),
            "compensated dynamics take held setpoints only"
        );
        self.advance_segment(state, u0, slope, h, &self.decay(h), Some(mu))
    }

    /// One interval with input u(τ) = u0 + v·τ. Each mode follows
    ///   zi(τ) = K u0 + s(τ − τi) + δi e^(−λi τ),  s = K v,  δi = zi(0) − K u0 + s τi,
    /// so I_tf(τ) = y + sτ + a δ1 e^(−λ1 τ) + b δ2 e^(−λ2 τ) with y = K u0 − s(a τp1 + b τp2).
    #[inline]
    fn advance_segment(
        &self,
        state: &mut CurrentState,
        u0: f64,
        v: f64,
        h: f64,
        decay: &Decay,
        mu: Option<f64>,
    ) -> CurrentIntegrals {
        let base = self.gain * u0;
        let s = self.gain * v;
        let y = base - s * (self.k1 + self.k2);
        let (dev1, dev2) = (
            state.z1 - base + s * self.tau1,
            state.z2 - base + s * self.tau2,
        );
        let tf0 = y + self.a * dev1 + self.b * dev2;
        let tracking = tf0 - state.current <= 1e-12 * tf0.abs().max(1.0);
        // Largest possible slope of I_tf on the step; at most r means the limit never binds.
        let max_rise =
            s + (-self.lambda1 * self.a * dev1).max(0.0) + (-self.lambda2 * self.b * dev2).max(0.0);
        state.z1 = base + s * (h - self.tau1) + dev1 * decay.e1;
        state.z2 = base + s * (h - self.tau2) + dev2 * decay.e2;
        let tf_end = self.unlimited_current(state);
        if tracking && max_rise <= self.ramp {
            let (charge, current_squared) = self.track_integrals(y, s, dev1, dev2, h, decay);
            state.current = tf_end;
            let mut out = CurrentIntegrals {
                charge,
                current_squared,
                ..CurrentIntegrals::default()
            };
            if let Some(mu) = mu {
                self.add_track_moments(&mut out, y, s, dev1, dev2, 0.0, charge, h, decay, mu);
            }
            return out;
        }
        let start = if tracking {
            tf0
        } else {
            state.current.min(tf0)
        };
        let (integrals, limited_end) = self.limited_step(y, s, dev1, dev2, start, h, decay, mu);
        // I(h) = r·h + M(h) from the running minimum, never above I_tf(h).
        state.current = limited_end.min(tf_end);
        integrals
    }

    /// The general step: split [0, h] where h(τ) = I_tf(τ) − rτ is monotone, follow its
    /// running minimum, and integrate the ramp and tracking segments in closed form.
    /// Returns the integrals and the current r·h + M(h) at the end.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn limited_step(
        &self,
        y: f64,
        s: f64,
        dev1: f64,
        dev2: f64,
        start: f64,
        h: f64,
        decay: &Decay,
        mu: Option<f64>,
    ) -> (CurrentIntegrals, f64) {
        let curve = Curve {
            y,
            amp_a: self.a * dev1,
            amp_b: self.b * dev2,
            s,
            l1: self.lambda1,
            l2: self.lambda2,
            r: self.ramp - s,
            len: h,
            e1_len: decay.e1,
            e2_len: decay.e2,
        };
        // M: running minimum of h(τ) = I_tf(τ) − rτ; the current is I(τ) = M + rτ.
        let mut walk = RunningMinimum {
            m: start,
            out: CurrentIntegrals::default(),
            mu,
        };
        // h'' vanishes at most once (the inflection); between 0, it and len, h' is monotone, so
        // h is monotone, rises then falls, or falls then rises on each sub-interval.
        let mut p = curve.point(0.0);
        for q in curve
            .inflection()
            .into_iter()
            .chain(std::iter::once(curve.point(h)))
        {
            if q.t > p.t {
                let (sp, sq) = (curve.derivatives(&p)[1], curve.derivatives(&q)[1]);
                if sp > 0.0 && sq < 0.0 {
                    // Rises then falls. If h ends at or above M, or starts strictly above it
                    // (so h − M is positive up to one crossing and negative after it, all the
                    // bracketed search needs), the top need not be located.
                    let (hp, hq) = (curve.h(&p), curve.h(&q));
                    if hq >= walk.m {
                        self.add_ramp(&mut walk, p.t, q.t);
                    } else if hp > walk.m {
                        self.falling(&mut walk, &curve, dev1, dev2, &p, &q, decay);
                    } else {
                        let top = curve.point(self.slope_root(&curve, &p, &q, sp, sq));
                        self.add_ramp(&mut walk, p.t, top.t);
                        self.falling(&mut walk, &curve, dev1, dev2, &top, &q, decay);
                    }
                } else if sp < 0.0 && sq > 0.0 {
                    // Falls then rises: the bottom matters.
                    let bottom = curve.point(self.slope_root(&curve, &p, &q, sp, sq));
                    self.falling(&mut walk, &curve, dev1, dev2, &p, &bottom, decay);
                    self.add_ramp(&mut walk, bottom.t, q.t);
                } else if sp <= 0.0 && sq <= 0.0 {
                    self.falling(&mut walk, &curve, dev1, dev2, &p, &q, decay);
                } else {
                    // h rises: the running minimum holds, the current ramps.
                    self.add_ramp(&mut walk, p.t, q.t);
                }
            }
            p = q;
        }
        (walk.out, walk.m + self.ramp * h)
    }

    /// The zero of h' between p and q (h' is monotone there and changes sign).
    fn slope_root(&self, curve: &Curve, p: &Point, q: &Point, sp: f64, sq: f64) -> f64 {
        monotone_root(
            |t| {
                let [_, d1, d2, d3] = curve.derivatives(&curve.point(t));
                (d1, d2, d3)
            },
            p.t,
            q.t,
            sp,
            sq,
        )
    }

    /// A sub-interval [p, q] on which h falls, or rises then falls from h(p) > M: the current
    /// ramps while h stays above M, then tracks I_tf.
    #[allow(clippy::too_many_arguments)]
    fn falling(
        &self,
        walk: &mut RunningMinimum,
        curve: &Curve,
        dev1: f64,
        dev2: f64,
        p: &Point,
        q: &Point,
        decay: &Decay,
    ) {
        let (hp, hq) = (curve.h(p), curve.h(q));
        let m = walk.m;
        if hq >= m {
            self.add_ramp(walk, p.t, q.t);
        } else if hp <= m {
            self.add_track(walk, curve, dev1, dev2, p, q.t, decay);
            walk.m = hq;
        } else {
            let crossing = monotone_root(
                |t| {
                    let [v, d1, d2, _] = curve.derivatives(&curve.point(t));
                    (v - m, d1, d2)
                },
                p.t,
                q.t,
                hp - m,
                hq - m,
            );
            self.add_ramp(walk, p.t, crossing);
            self.add_track(walk, curve, dev1, dev2, &curve.point(crossing), q.t, decay);
            walk.m = hq;
        }
    }

    /// Ramp segment [s0, s1]: I = I0 + r(τ − s0) with I0 = M + r·s0; with moments (σ = τ − s0,
    /// L = s1 − s0) ∫τ·I = s0·∫I + I0 L²/2 + r L³/3 and
    /// ∫e^(−μτ)·I = e^(−μ s0)·(I0·E(μ) + r·J(μ)) ([`decay_integral`], [`decay_moment`]).
    fn add_ramp(&self, walk: &mut RunningMinimum, s0: f64, s1: f64) {
        let out = &mut walk.out;
        let length = s1 - s0;
        let i0 = walk.m + self.ramp * s0;
        let r = self.ramp;
        let charge = i0 * length + 0.5 * r * length * length;
        out.charge += charge;
        out.current_squared +=
            i0 * i0 * length + i0 * r * length * length + r * r * length.powi(3) / 3.0;
        out.ramp_time += length;
        if let Some(mu) = walk.mu {
            let (l2, l3) = (length * length, length * length * length);
            out.time_moment += s0 * charge + 0.5 * i0 * l2 + r * l3 / 3.0;
            out.decay_moment +=
                (-mu * s0).exp() * (i0 * decay_integral(mu, length) + r * decay_moment(mu, length));
        }
    }

    /// Tracking segment [start, s1] of a step whose modal deviations were δ1, δ2 at τ = 0;
    /// `step` is the decay over the whole step, reused when the segment is the whole step.
    #[allow(clippy::too_many_arguments)]
    fn add_track(
        &self,
        walk: &mut RunningMinimum,
        curve: &Curve,
        dev1: f64,
        dev2: f64,
        start: &Point,
        s1: f64,
        step: &Decay,
    ) {
        let length = s1 - start.t;
        let segment = if start.t == 0.0 && s1 == curve.len {
            *step
        } else {
            self.decay(length)
        };
        let y = curve.y + curve.s * start.t;
        let (d1, d2) = (dev1 * start.e1, dev2 * start.e2);
        let (charge, squared) = self.track_integrals(y, curve.s, d1, d2, length, &segment);
        let out = &mut walk.out;
        out.charge += charge;
        out.current_squared += squared;
        if let Some(mu) = walk.mu {
            self.add_track_moments(
                out, y, curve.s, d1, d2, start.t, charge, length, &segment, mu,
            );
        }
    }

    /// The moments of a tracking segment that starts `t0` [s] into the step, on which
    /// I(σ) = y + sσ + A e^(−λ1 σ) + B e^(−λ2 σ) (A = a δ1, B = b δ2, σ = τ − t0) and
    /// ∫I = `charge`:
    ///   ∫τ·I = t0·∫I + y L²/2 + s L³/3 + A·J(λ1) + B·J(λ2),
    ///   ∫e^(−μτ)·I = e^(−μ t0)·(y E(μ) + s J(μ) + A E(λ1 + μ) + B E(λ2 + μ)),
    /// with E(κ) = ∫₀ᴸ e^(−κσ) dσ and J(κ) = ∫₀ᴸ σ e^(−κσ) dσ.
    #[allow(clippy::too_many_arguments)]
    fn add_track_moments(
        &self,
        out: &mut CurrentIntegrals,
        y: f64,
        s: f64,
        dev1: f64,
        dev2: f64,
        t0: f64,
        charge: f64,
        length: f64,
        decay: &Decay,
        mu: f64,
    ) {
        let (big_a, big_b) = (self.a * dev1, self.b * dev2);
        let (l2, l3) = (length * length, length * length * length);
        let j1 = self.tau1 * self.tau1 * ramp_moment(self.lambda1 * length, decay.e1);
        let j2 = self.tau2 * self.tau2 * ramp_moment(self.lambda2 * length, decay.e2);
        out.time_moment += t0 * charge + 0.5 * y * l2 + s * l3 / 3.0 + big_a * j1 + big_b * j2;
        out.decay_moment += (-mu * t0).exp()
            * (y * decay_integral(mu, length)
                + s * decay_moment(mu, length)
                + big_a * decay_integral(self.lambda1 + mu, length)
                + big_b * decay_integral(self.lambda2 + mu, length));
    }
}

/// E(κ) = ∫₀ᴸ e^(−κσ) dσ = (1 − e^(−κL))/κ [s] for κ ≥ 0 (L at κ = 0).
fn decay_integral(kappa: f64, length: f64) -> f64 {
    if kappa == 0.0 {
        length
    } else {
        -(-kappa * length).exp_m1() / kappa
    }
}

/// J(κ) = ∫₀ᴸ σ e^(−κσ) dσ = (1 − (1 + κL) e^(−κL))/κ² [s²] for κ ≥ 0 (L²/2 at κ = 0).
fn decay_moment(kappa: f64, length: f64) -> f64 {
    if kappa == 0.0 {
        0.5 * length * length
    } else {
        let x = kappa * length;
        ramp_moment(x, (-x).exp()) / (kappa * kappa)
    }
}

/// 1 − (1 + x) e^(−x) for x ≥ 0 (the first moment of a decaying exponential, scaled),
/// by its series where the closed form would cancel.
fn ramp_moment(x: f64, e: f64) -> f64 {
    if x < 0.05 {
        // Σ_{k≥2} (−1)^k (k − 1) x^k / k!
        let mut term = x * x / 2.0;
        let mut sum = 0.0;
        for k in 2..12 {
            sum += (k - 1) as f64 * term;
            term *= -x / (k + 1) as f64;
        }
        sum
    } else {
        1.0 - (1.0 + x) * e
    }
}

/// The running minimum M of h over the step so far, and the integrals accumulated.
struct RunningMinimum {
    m: f64,
    out: CurrentIntegrals,
    /// The rate μ [1/s] of the moments to accumulate, if any.
    mu: Option<f64>,
}

/// A time τ in the step with both mode decays e^(−λi τ), evaluated once.
#[derive(Clone, Copy, Debug)]
struct Point {
    t: f64,
    e1: f64,
    e2: f64,
}

/// h(τ) = I_tf(τ) − rτ = y + A e^(−λ1 τ) + B e^(−λ2 τ) − (r − s)τ over one step [A]
/// (s: slope of an interpolated input's steady current, 0 for a constant setpoint).
struct Curve {
    y: f64,
    s: f64,
    amp_a: f64,
    amp_b: f64,
    l1: f64,
    l2: f64,
    /// Net slope r − s of the line subtracted from I_tf's exponentials [A/s].
    r: f64,
    /// Step length and e^(−λi len), known from the step factors.
    len: f64,
    e1_len: f64,
    e2_len: f64,
}

impl Curve {
    /// The point at τ; free at the ends of the step.
    fn point(&self, t: f64) -> Point {
        if t == 0.0 {
            Point {
                t,
                e1: 1.0,
                e2: 1.0,
            }
        } else if t == self.len {
            Point {
                t,
                e1: self.e1_len,
                e2: self.e2_len,
            }
        } else {
            Point {
                t,
                e1: (-self.l1 * t).exp(),
                e2: (-self.l2 * t).exp(),
            }
        }
    }

    /// h(τ) [A].
    fn h(&self, p: &Point) -> f64 {
        self.y + self.amp_a * p.e1 + self.amp_b * p.e2 - self.r * p.t
    }

    /// h and its first three derivatives at a point.
    fn derivatives(&self, p: &Point) -> [f64; 4] {
        let (ea, eb) = (self.amp_a * p.e1, self.amp_b * p.e2);
        let (l1, l2) = (self.l1, self.l2);
        [
            self.y + ea + eb - self.r * p.t,
            -l1 * ea - l2 * eb - self.r,
            l1 * l1 * ea + l2 * l2 * eb,
            -l1 * l1 * l1 * ea - l2 * l2 * l2 * eb,
        ]
    }

    /// The zero of h'' = λ1² A e^(−λ1 τ) + λ2² B e^(−λ2 τ) inside the step, if any (it exists
    /// only where A·B < 0, and is unique).
    fn inflection(&self) -> Option<Point> {
        if self.amp_a * self.amp_b >= 0.0 {
            return None;
        }
        let ratio = -(self.l2 * self.l2 * self.amp_b) / (self.l1 * self.l1 * self.amp_a);
        let t = ratio.ln() / (self.l2 - self.l1);
        (t > 0.0 && t < self.len).then(|| self.point(t))
    }
}

#[cfg(test)]
mod filter_tests;

#[cfg(test)]
mod tests {
    use super::*;

    fn paper() -> (Parameters, CurrentDynamics) {
        let p = Parameters::default();
        (p, CurrentDynamics::new(&p))
    }

    #[test]
    fn the_tracking_envelope_holds_the_current_and_its_integrals() {
        let (_, d) = paper();
        let mut rising = d.steady_state(70.0);
        d.advance(&mut rising, 75.0, 200.0, &mut StepFactors::default());
        for (start, u, h) in [
            (d.steady_state(80.0), 65.0, 1.0),
            (d.steady_state(80.0), 65.0, 40.0),
            (rising, 75.0, 3.0),
            (rising, 71.0, 50.0),
        ] {
            let env = d.tracking_envelope(&start, u, h).expect("tracks");
            let mut ints = CurrentIntegrals::default();
            let (mut lo, mut hi) = (start.current, start.current);
            let n = 4000;
            let mut s = start;
            for _ in 0..n {
                let piece = d.advance(&mut s, u, h / n as f64, &mut StepFactors::default());
                ints.charge += piece.charge;
                ints.current_squared += piece.current_squared;
                lo = lo.min(s.current);
                hi = hi.max(s.current);
            }
            assert!((env.charge - ints.charge).abs() < 1e-9 * ints.charge);
            assert!(
                (env.current_squared - ints.current_squared).abs() < 1e-9 * ints.current_squared
            );
            // The sampled extremes lie within the exact ones, and close to them.
            assert!(
                env.min <= lo + 1e-12 && env.max >= hi - 1e-12,
                "{env:?} vs {lo} {hi}"
            );
            assert!(
                lo - env.min < 1e-6 && env.max - hi < 1e-6,
                "{env:?} vs {lo} {hi}"
            );
        }
        // A step where the rate limit binds has no envelope.
        assert!(d
            .tracking_envelope(&d.steady_state(60.0), 100.0, 5.0)
            .is_none());
    }

    /// Closed-form unlimited response to a setpoint step u0 → u1 from steady state:
    /// I_tf(t) = K u1 + K(u0 − u1)(a e^(−t/τp1) + b e^(−t/τp2)).
    fn step_response(p: &Parameters, u0: f64, u1: f64, t: f64) -> f64 {
        let a = (p.tau_zero - p.tau_pole1) / (p.tau_pole2 - p.tau_pole1);
        let b = 1.0 - a;
        p.gain * u1
            + p.gain * (u0 - u1) * (a * (-t / p.tau_pole1).exp() + b * (-t / p.tau_pole2).exp())
    }

    fn simulate(d: &CurrentDynamics, u0: f64, u1: f64, h: f64, t_end: f64) -> (CurrentState, f64) {
        let mut s = d.steady_state(u0);
        let mut f = StepFactors::default();
        let n = (t_end / h).round() as usize;
        let mut charge = 0.0;
        for _ in 0..n {
            charge += d.advance(&mut s, u1, h, &mut f).charge;
        }
        (s, charge)
    }

    #[test]
    fn negative_step_follows_two_exponentials() {
        let (p, d) = paper();
        for &t in &[0.5, 1.0, 7.0, 60.0, 300.0, 1000.0] {
            let (s, _) = simulate(&d, 100.0, 70.0, 0.5, t);
            let want = step_response(&p, 100.0, 70.0, t);
            assert!(
                (s.current - want).abs() < 1e-9,
                "t={t}: {} vs {want}",
                s.current
            );
        }
    }

    #[test]
    fn positive_step_ramps_then_tracks() {
        let (p, d) = paper();
        // Unlimited response rises faster than r at first: the current ramps from K·u0 at r
        // until it meets I_tf; the meeting instant solves K u0 + r t = I_tf(t).
        let (u0, u1) = (60.0, 100.0);
        let f = |t: f64| step_response(&p, u0, u1, t) - (p.gain * u0 + p.ramp_up_limit * t);
        let (mut lo, mut hi) = (1.0, 5000.0);
        assert!(f(lo) > 0.0 && f(hi) < 0.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if f(mid) > 0.0 {
                lo = mid
            } else {
                hi = mid
            }
        }
        let meet = lo;
        for &t in &[1.0, 10.0, meet - 1.0, meet + 1.0, meet + 200.0, 2000.0] {
            let t = (t * 4.0_f64).round() / 4.0;
            let (s, _) = simulate(&d, u0, u1, 0.25, t);
            let want = if t < meet {
                p.gain * u0 + p.ramp_up_limit * t
            } else {
                step_response(&p, u0, u1, t)
            };
            assert!(
                (s.current - want).abs() < 1e-9,
                "t={t}: {} vs {want}",
                s.current
            );
        }
    }

    /// Compensated: a falling step is the first order K u1 + K(u0 − u1) e^(−t/τp1) with its
    /// charge in closed form; a rising one ramps at r until it meets it; neither leaves the
    /// currents of the window, and results do not depend on the step size.
    #[test]
    fn compensation_turns_steps_into_the_fast_first_order() {
        let p = Parameters::default();
        let d = CurrentDynamics::new(&p).with_compensation(true);
        let (k, t1, r) = (p.gain, p.tau_pole1, p.ramp_up_limit);
        let first_order = |u0: f64, u1: f64, t: f64| k * u1 + k * (u0 - u1) * (-t / t1).exp();
        for &t in &[0.5, 2.0, 7.5, 30.0, 400.0] {
            let (s, charge) = simulate(&d, 90.0, 60.0, 0.5, t);
            assert!(
                (s.current - first_order(90.0, 60.0, t)).abs() < 1e-9,
                "t={t}: {}",
                s.current
            );
            let want = k * 60.0 * t + k * 30.0 * t1 * (1.0 - (-t / t1).exp());
            assert!(
                (charge - want).abs() < 1e-9 * want,
                "t={t}: charge {charge} vs {want}"
            );
        }
        // Rising 60 → 61 %: the first order rises faster than r at first, so the current ramps
        // from K·60 until K·60 + r t meets it.
        let f = |t: f64| first_order(60.0, 61.0, t) - (k * 60.0 + r * t);
        let (mut lo, mut hi) = (1e-6, 100.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if f(mid) > 0.0 {
                lo = mid
            } else {
                hi = mid
            }
        }
        for &t in &[0.5, 1.0, 2.0, 4.0, 10.0, 60.0] {
            let (s, _) = simulate(&d, 60.0, 61.0, 0.25, t);
            let want = if t < lo {
                k * 60.0 + r * t
            } else {
                first_order(60.0, 61.0, t)
            };
            assert!(
                (s.current - want).abs() < 1e-9,
                "t={t}: {} vs {want}",
                s.current
            );
        }
        let schedule = [
            (100.0, 30.0),
            (60.0, 45.0),
            (85.0, 61.0),
            (60.0, 17.0),
            (100.0, 300.0),
        ];
        let run = |h: f64| {
            let mut s = d.steady_state(80.0);
            let mut f = StepFactors::default();
            let mut out = Vec::new();
            for &(u, dur) in &schedule {
                for _ in 0..(dur / h).round() as usize {
                    d.advance(&mut s, u, h, &mut f);
                    let i_tf = d.unlimited_current(&s);
                    assert!(
                        i_tf >= k * 60.0 - 1e-9 && i_tf <= k * 100.0 + 1e-9,
                        "I_tf {i_tf} left the window"
                    );
                    assert!(s.current <= i_tf + 1e-9);
                }
                out.push(s.current);
            }
            out
        };
        let reference = run(1.0);
        for h in [0.25, 0.5] {
            for (got, want) in run(h).iter().zip(&reference) {
                assert!((got - want).abs() < 1e-9, "h={h}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn step_size_does_not_change_results() {
        let (_, d) = paper();
        let schedule = [
            (100.0, 120.0),
            (60.0, 300.0),
            (85.0, 60.0),
            (65.0, 420.0),
            (100.0, 600.0),
        ];
        let run = |h: f64| {
            let mut s = d.steady_state(80.0);
            let mut f = StepFactors::default();
            let mut charge = 0.0;
            let mut out = Vec::new();
            for &(u, dur) in &schedule {
                for _ in 0..(dur / h).round() as usize {
                    charge += d.advance(&mut s, u, h, &mut f).charge;
                }
                out.push((s.current, charge));
            }
            out
        };
        let reference = run(60.0);
        for h in [0.01, 0.1, 1.0, 5.0, 20.0] {
            for (i, (got, want)) in run(h).iter().zip(&reference).enumerate() {
                assert!(
                    (got.0 - want.0).abs() < 1e-9,
                    "h={h} segment {i}: {} vs {}",
                    got.0,
                    want.0
                );
                assert!((got.1 - want.1).abs() < 1e-6 * want.1, "h={h} charge {i}");
            }
        }
    }

    #[test]
    fn charge_of_a_ramp_is_exact() {
        let (p, d) = paper();
        // 60 → 100 %: the first 10 s are a pure ramp from 32.04 A at 0.22 A/s.
        let (_, q) = simulate(&d, 60.0, 100.0, 10.0, 10.0);
        let want = p.gain * 60.0 * 10.0 + 0.5 * p.ramp_up_limit * 100.0;
        assert!((q - want).abs() < 1e-9, "{q} vs {want}");
    }

    /// Moments over [0, h] summed from pieces of length `piece`: each piece's moments about
    /// its own start, moved to the step's start (τ = t + σ: ∫τI = t·∫I + ∫σI, ∫e^(−μτ)I =
    /// e^(−μt)·∫e^(−μσ)I).
    fn moments_in_pieces(
        d: &CurrentDynamics,
        u: impl Fn(f64) -> f64,
        h: f64,
        piece: f64,
        mu: f64,
    ) -> (f64, f64, f64) {
        let mut state = d.steady_state(60.0);
        let (mut charge, mut time, mut decay) = (0.0, 0.0, 0.0);
        let n = (h / piece).round() as usize;
        for k in 0..n {
            let t = k as f64 * piece;
            let ints = d.advance_with_moments(&mut state, u(t), piece, mu);
            time += t * ints.charge + ints.time_moment;
            decay += (-mu * t).exp() * ints.decay_moment;
            charge += ints.charge;
        }
        (charge, time, decay)
    }

    #[test]
    fn moments_of_a_steady_current_are_the_closed_forms() {
        let (p, d) = paper();
        let mut state = d.steady_state(80.0);
        let (h, mu) = (900.0, 1.0 / 3600.0);
        let ints = d.advance_with_moments(&mut state, 80.0, h, mu);
        let i = p.gain * 80.0;
        assert!((ints.time_moment - i * h * h / 2.0).abs() < 1e-9 * i * h * h);
        let want = i * (1.0 - (-mu * h).exp()) / mu;
        assert!((ints.decay_moment - want).abs() < 1e-12 * want);
        // The plain step's integrals are unchanged by asking for moments.
        let mut plain = d.steady_state(80.0);
        let without = d.advance(&mut plain, 80.0, h, &mut StepFactors::default());
        assert_eq!(ints.charge, without.charge);
        assert_eq!(plain, state);
    }

    #[test]
    fn moments_do_not_depend_on_the_step_size_through_ramps_and_falls() {
        let (_, d) = paper();
        // Up 60 → 100 % (the ramp limit binds, then the current tracks), down at 300 s.
        let u = |t: f64| if t < 300.0 { 100.0 } else { 65.0 };
        let mu = 1.0 / 500.0;
        let whole = moments_in_pieces(&d, u, 600.0, 300.0, mu);
        for piece in [0.5, 7.5, 60.0] {
            let cut = moments_in_pieces(&d, u, 600.0, piece, mu);
            for (a, b) in [(whole.0, cut.0), (whole.1, cut.1), (whole.2, cut.2)] {
                assert!((a - b).abs() <= 1e-10 * a.abs(), "{piece}: {a} vs {b}");
            }
        }
        // Against the trapezoid rule on the current sampled every 1 ms.
        let mut state = d.steady_state(60.0);
        let (mut time, mut decay, mut last) = (0.0, 0.0, state.current);
        let dt = 1e-3;
        for k in 1..=600_000 {
            let t = k as f64 * dt;
            d.advance(&mut state, u(t - dt), dt, &mut StepFactors::default());
            let (t0, i0, i1) = (t - dt, last, state.current);
            time += 0.5 * dt * (t0 * i0 + t * i1);
            decay += 0.5 * dt * ((-mu * t0).exp() * i0 + (-mu * t).exp() * i1);
            last = i1;
        }
        assert!(
            (whole.1 - time).abs() < 1e-7 * time,
            "{} vs {time}",
            whole.1
        );
        assert!(
            (whole.2 - decay).abs() < 1e-7 * decay,
            "{} vs {decay}",
            whole.2
        );
    }

    #[test]
    fn moments_of_an_interpolated_input_add_up_over_pieces() {
        let (_, d) = paper();
        let mu = 1.0 / 2000.0;
        let mut whole_state = d.steady_state(60.0);
        let whole = d.advance_linear_with_moments(&mut whole_state, 60.0, 0.05, 400.0, mu);
        let mut state = d.steady_state(60.0);
        let (mut time, mut decay) = (0.0, 0.0);
        for k in 0..40 {
            let t = 10.0 * k as f64;
            let ints = d.advance_linear_with_moments(&mut state, 60.0 + 0.05 * t, 0.05, 10.0, mu);
            time += t * ints.charge + ints.time_moment;
            decay += (-mu * t).exp() * ints.decay_moment;
        }
        assert!((whole.time_moment - time).abs() < 1e-10 * time);
        assert!((whole.decay_moment - decay).abs() < 1e-10 * decay);
    }
}
