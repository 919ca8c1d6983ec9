//! A second record generator, different in form from the project's simulator: a Prony-series
//! finger of three to five Kelvin modes simulated at eight times the record's rate, its own
//! excitation (indentations to random depths, sine bursts, rests), and effects written in other
//! forms than the diagnosis's regressors (each mode stiffening by its own law, a Duhem-type
//! hysteresis, a drift that wanders, interference off the mains frequency, delays of whole
//! samples, an extra slow mode, a sensitivity that sags or cycles). For tests and benchmarks.

use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;

/// An effect switched on in a generated record, with its strength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SynthEffect {
    /// Each mode's compliance falls with load as 1/(1 + s·(σ/50 g)^p), p its own.
    Stiffening(f64),
    /// Duhem hysteresis: a loop `width` × the record's peak strain wide.
    Hysteresis(f64),
    /// A wandering zero: an exponential settling plus a slow oscillation, `amplitude` × peak strain.
    Drift(f64),
    /// A tone of `amplitude` × peak strain at `hz`, its amplitude breathing slowly.
    Interference { amplitude: f64, hz: f64 },
    /// The strain arrives this many samples late.
    Delay(usize),
    /// An extra Kelvin mode of time constant `tau_s` and compliance `share` × the elastic one.
    SlowRelaxation { share: f64, tau_s: f64 },
    /// The sensitivity falls linearly by this fraction over the record.
    SensitivityDrift(f64),
    /// Not an effect but the memo's own finger (eq. 14): the creep levels off with time
    /// constant `tau_s` = N₁/α, its rate `rate_per_s` × the elastic compliance per second.
    Eq14Creep { tau_s: f64, rate_per_s: f64 },
    /// The sensitivity swings by ± `amplitude` (a share) with period `period_s`, as a
    /// temperature cycle moves it.
    GainCycle { amplitude: f64, period_s: f64 },
    /// The zero swings by ± `amplitude` × peak strain with period `period_s`.
    ZeroCycle { amplitude: f64, period_s: f64 },
}

impl core::str::FromStr for SynthEffect {
    type Err = String;

    /// `NAME=VALUE` or `NAME=VALUE@X`: stiffening=S, hysteresis=W, drift=A, interference=A@HZ,
    /// delay=SAMPLES, slow=SHARE@TAU_S, sag=FRACTION, eq14=RATE_PER_S@TAU_S,
    /// gaincycle=AMPLITUDE@PERIOD_S, zerocycle=AMPLITUDE@PERIOD_S.
    fn from_str(arg: &str) -> Result<Self, String> {
        let (name, value) = arg
            .split_once('=')
            .ok_or(format!("{arg}: expected NAME=VALUE"))?;
        let (v, at) = match value.split_once('@') {
            Some((v, at)) => (v, Some(at)),
            None => (value, None),
        };
        let num = |s: &str| s.parse::<f64>().map_err(|e| format!("{arg}: {e}"));
        let at = || at.ok_or(format!("{arg}: expected VALUE@X")).and_then(num);
        Ok(match name {
            "stiffening" => SynthEffect::Stiffening(num(v)?),
            "hysteresis" => SynthEffect::Hysteresis(num(v)?),
            "drift" => SynthEffect::Drift(num(v)?),
            "interference" => SynthEffect::Interference {
                amplitude: num(v)?,
                hz: at()?,
            },
            "delay" => SynthEffect::Delay(num(v)?.max(0.0) as usize),
            "slow" => SynthEffect::SlowRelaxation {
                share: num(v)?,
                tau_s: at()?,
            },
            "sag" => SynthEffect::SensitivityDrift(num(v)?),
            "eq14" => SynthEffect::Eq14Creep {
                rate_per_s: num(v)?,
                tau_s: at()?,
            },
            "gaincycle" => SynthEffect::GainCycle {
                amplitude: num(v)?,
                period_s: at()?,
            },
            "zerocycle" => SynthEffect::ZeroCycle {
                amplitude: num(v)?,
                period_s: at()?,
            },
            _ => return Err(format!("{arg}: unknown effect")),
        })
    }
}

/// What to generate.
#[derive(Clone, Debug)]
pub struct Spec {
    pub seed: u64,
    pub rate_hz: f64,
    pub duration_s: f64,
    pub effects: Vec<SynthEffect>,
}

/// A generated record: evenly sampled measured force (g) and strain (%), and the true force.
#[derive(Clone, Debug)]
pub struct Generated {
    pub dt_s: f64,
    pub force_g: Vec<f64>,
    pub strain_pct: Vec<f64>,
    pub true_force_g: Vec<f64>,
}

/// The excitation: piecewise-linear knots (t, force) and sine bursts, as a function of time.
struct Excitation {
    knots: Vec<(f64, f64)>,
    bursts: Vec<(f64, f64, f64, f64)>, // start, end, amplitude, hz
}

impl Excitation {
    fn new(rng: &mut Xoshiro256PlusPlus, duration_s: f64) -> Excitation {
        let mut knots = vec![(0.0, 0.0), (1.5, 0.0)];
        let mut bursts = Vec::new();
        let mut t = 1.5;
        let mut level: f64 = 0.0;
        while t < duration_s {
            let kind: f64 = rng.random();
            if kind < 0.6 {
                // An indentation: ramp to a random depth, hold, maybe release.
                let target = rng.random_range(5.0..80.0);
                let rate = rng.random_range(20.0..200.0);
                t += (target - level).abs() / rate + 0.01;
                knots.push((t, target));
                t += rng.random_range(0.5..6.0);
                knots.push((t, target));
                level = target;
                if rng.random::<f64>() < 0.4 {
                    t += level / rate + 0.01;
                    knots.push((t, 0.0));
                    t += rng.random_range(0.5..4.0);
                    knots.push((t, 0.0));
                    level = 0.0;
                }
            } else {
                // A sine burst about a mean load.
                let mean = rng.random_range(20.0..45.0);
                t += (mean - level).abs() / 100.0 + 0.01;
                knots.push((t, mean));
                let hz = 10f64.powf(rng.random_range(-1.3..0.6));
                let length = (rng.random_range(2.0..4.0) / hz).min(12.0);
                let amplitude = rng.random_range(4.0..15.0);
                bursts.push((t, t + length, amplitude, hz));
                t += length;
                knots.push((t, mean));
                level = mean;
            }
        }
        Excitation { knots, bursts }
    }

    fn at(&self, t: f64) -> f64 {
        let i = self.knots.partition_point(|k| k.0 <= t);
        let base = match (self.knots.get(i.wrapping_sub(1)), self.knots.get(i)) {
            (Some(a), Some(b)) => a.1 + (b.1 - a.1) * (t - a.0) / (b.0 - a.0).max(1e-12),
            (Some(a), None) => a.1,
            _ => 0.0,
        };
        let burst: f64 = self
            .bursts
            .iter()
            .filter(|b| t >= b.0 && t < b.1)
            .map(|b| b.2 * (2.0 * std::f64::consts::PI * b.3 * (t - b.0)).sin())
            .sum();
        (base + burst).max(0.0)
    }
}

/// Generates a record.
pub fn generate(spec: &Spec) -> Generated {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(spec.seed);
    let dt = 1.0 / spec.rate_hz;
    let n = (spec.duration_s * spec.rate_hz).round() as usize;
    let over = 8usize;
    let h = dt / over as f64;
    let excitation = Excitation::new(&mut rng, spec.duration_s);
    // The finger: an elastic compliance and 3–5 Kelvin modes from 0.08 to 12 s.
    let j0 = rng.random_range(0.15..0.35);
    let modes_n = rng.random_range(3..=5);
    let mut modes: Vec<(f64, f64, f64, f64)> = (0..modes_n)
        .map(|_| {
            let tau = 10f64.powf(rng.random_range(-1.1..1.08));
            let j = j0 * rng.random_range(0.1..0.45);
            let p = rng.random_range(0.6..1.4);
            (tau, j, p, 0.0)
        })
        .collect();
    let mut creep = j0 * rng.random_range(0.0..2e-4);
    // τ₁ = N₁/α; infinite: eq. 11's permanent creep.
    let mut creep_tau_s = f64::INFINITY;
    let mut stiff = 0.0;
    let mut hyst = 0.0;
    let mut drift = 0.0;
    let mut tone = (0.0, 0.0);
    let mut delay = 0usize;
    let mut sag = 0.0;
    let mut cycle = (0.0, f64::INFINITY);
    let mut zero_cycle = (0.0, f64::INFINITY);
    for e in &spec.effects {
        match *e {
            SynthEffect::Stiffening(s) => stiff = s,
            SynthEffect::Hysteresis(w) => hyst = w,
            SynthEffect::Drift(a) => drift = a,
            SynthEffect::Interference { amplitude, hz } => tone = (amplitude, hz),
            SynthEffect::Delay(d) => delay = d,
            SynthEffect::SlowRelaxation { share, tau_s } => {
                modes.push((tau_s, j0 * share, 1.0, 0.0));
            }
            SynthEffect::SensitivityDrift(g) => sag = g,
            SynthEffect::GainCycle {
                amplitude,
                period_s,
            } => cycle = (amplitude, period_s),
            SynthEffect::ZeroCycle {
                amplitude,
                period_s,
            } => zero_cycle = (amplitude, period_s),
            SynthEffect::Eq14Creep { tau_s, rate_per_s } => {
                creep = j0 * rate_per_s;
                creep_tau_s = tau_s;
            }
        }
    }
    let elastic_p = rng.random_range(0.6..1.4);
    let compliance = |j: f64, p: f64, f: f64| j / (1.0 + stiff * (f / 50.0).powf(p));
    // Duhem hysteresis: dz = a·dσ − b·|dσ|·z, a loop about 2a/b wide at saturation.
    let peak_strain = 80.0 * (j0 + modes.iter().map(|m| m.1).sum::<f64>());
    let b_duhem = 1.0 / 15.0;
    let a_duhem = hyst * peak_strain * b_duhem / 2.0;
    let mut z = 0.0;
    let mut creep_state = 0.0;
    let mut prev_f = 0.0;
    let mut clean = Vec::with_capacity(n);
    let mut true_force = Vec::with_capacity(n);
    for i in 0..n {
        // Sub-steps from the previous sample up to this one (the strain never sees ahead).
        for k in 1..=over {
            let t = (i as f64 - 1.0) * dt + k as f64 * h;
            let f = excitation.at(t);
            for m in modes.iter_mut() {
                let target = compliance(m.1, m.2, f) * f;
                m.3 = target + (m.3 - target) * (-h / m.0).exp();
            }
            let df = f - prev_f;
            // The strain lags on loading and leads on unloading, as in a lossy material. Solved
            // exactly over the sub-step: a burst that ends mid-swing steps the force by up to
            // 15 g within one, where an Euler step (b·|dσ| ≈ 1) threw z to the far side.
            if df != 0.0 {
                let side = -a_duhem / b_duhem * df.signum();
                z = side + (z - side) * (-b_duhem * df.abs()).exp();
            }
            creep_state += (creep * f - creep_state / creep_tau_s) * h;
            prev_f = f;
        }
        let t = i as f64 * dt;
        let f = excitation.at(t);
        let e = compliance(j0, elastic_p, f) * f
            + modes.iter().map(|m| m.3).sum::<f64>()
            + creep_state
            + z;
        let gain = 1.0 - sag * t / spec.duration_s
            + cycle.0 * (2.0 * std::f64::consts::PI * t / cycle.1).sin();
        true_force.push(f);
        clean.push(gain * e);
    }
    // Additive parts, then the delay, then the noise (the read-out's, after the delay).
    let phase = rng.random_range(0.0..std::f64::consts::TAU);
    let period = rng.random_range(60.0..200.0f64).min(spec.duration_s);
    let tau_settle = rng.random_range(0.1..0.4) * spec.duration_s;
    let strain_noise = Normal::new(0.0, 0.022 * j0).expect("finite");
    let force_noise = Normal::new(0.0, 0.14).expect("finite");
    let mut strain = Vec::with_capacity(n);
    let mut force = Vec::with_capacity(n);
    for i in 0..n {
        let t = i as f64 * dt;
        let mut e = clean[i.saturating_sub(delay)];
        e += drift
            * peak_strain
            * (0.6 * (1.0 - (-t / tau_settle).exp())
                + 0.4 * (2.0 * std::f64::consts::PI * t / period + phase).sin());
        e += zero_cycle.0 * peak_strain * (2.0 * std::f64::consts::PI * t / zero_cycle.1).sin();
        e += tone.0
            * peak_strain
            * (1.0 + 0.2 * (0.05 * t).sin())
            * (2.0 * std::f64::consts::PI * tone.1 * t).sin();
        strain.push(e + strain_noise.sample(&mut rng));
        force.push(true_force[i] + force_noise.sample(&mut rng));
    }
    Generated {
        dt_s: dt,
        force_g: force,
        strain_pct: strain,
        true_force_g: true_force,
    }
}
