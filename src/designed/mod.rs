//! The designed force controller: two degrees of freedom, each doing what it can do
//! on this plant.
//!
//! - **Reference model**: the (slew-limited) command through a triple real pole at
//!   `reference_hz`, integrated exactly over each tick (the input ramping between commands);
//!   its states are the force the loop should have and its first two derivatives; its third
//!   is the second's backward difference over two ticks.
//! - **Feed-forward**: the drive that makes the identified plant follow that force: the plant's
//!   inverse as a series in s, `u_ff = c₀y + c₁y' + c₂y'' + c₃y'''`, its coefficients scheduled on
//!   the reference force (the inertia–finger mode stiffens with load). A series needs no poles
//!   of its own, so nothing in the feed-forward can ring; truncated after s³ it is exact for the
//!   mode and the amplifier's pole and a few per cent off at 40 Hz for the beam.
//! - **Feedback**: proportional and integral action on the error against the reading the
//!   reference predicts ([`READING_LAG_TICKS`], and the tip's inertia the gauge reads besides
//!   the contact force: `gauge_s2`): against anything else the feedback fights the feed-forward
//!   over what the gauge cannot read. The error passes a biquad the design chooses (none, a
//!   notch at the beam's mode or a low-pass: the gauge sits on the beam, whose mode is barely
//!   damped; unfiltered, a gain of 0.2 left a gain margin of 0.6–1.0 on the friction-free
//!   plant). Its gains are set by the margins; it removes what the model and the stiction
//!   leave.
//!
//! While the supervisor re-approaches the finger, the integral holds (the gauge reads the tip's
//! inertia in the air, not a force to correct).
//!
//! - **Touch-down**: the gauge reads nothing of the gap, so force control cannot tell flight
//!   from a rest on the finger, and in flight it accelerates the probe until it strikes (from
//!   1 mm off the memo rig's finger, a 10 g command landed at 34 g). Until the gauge reads
//!   contact the drive is a train of pulses instead: [`APPROACH_TICKS`] ticks at the
//!   stiction (`approach_hold_g`) and a smooth push on it ([`APPROACH_SHAPE`], peaking at
//!   `approach_push_g`), then a smooth brake as long (peaking at `approach_brake_g`).
//!   Each push gives the probe a bounded momentum (what the push has beyond the friction, over
//!   its length), and the brake takes it back (or the friction does), so the probe steps toward
//!   the finger at a bounded speed however far off it is, and strikes it with that momentum at
//!   most. Contact is [`CONTACT_COUNT`] of the last [`CONTACT_TICKS`] readings at
//!   `contact_g`, or a pulse cycle's mean reading at half of it (a light friction lets the
//!   brake pull the pressed probe back). Force control then starts from the cycle's mean
//!   reading (the last one rings with the free beam), the command ramping up from it
//!   ([`TOUCH_RATE_G_PER_S`], [`TOUCH_TAU_S`]). A command at or below zero rests the probe (no
//!   drive); once no recent reading is at `contact_g`, the next command touches down again. A
//!   rig whose friction has grown past the push since it was identified does not move: the
//!   supervisor's contact limit latches.
//!
//! ```
//! use tactile_core::designed::{DesignedController, DesignedConfig};
//! // A plant that is a unit gain: c = (1, 0, 0, 0) at every load.
//! let mut loop_ = DesignedController::new(DesignedConfig::UNIT_PLANT).unwrap();
//! let mut drive = 0.0;
//! for _ in 0..1000 {
//!     drive = loop_.update(10.0, drive, true).force_g;
//! }
//! assert!((drive - 10.0).abs() < 1e-3, "{drive}");
//! ```

use crate::control::Adjusted;

mod config;
mod friction;

pub use config::{
    DesignedConfig, DesignedError, InverseSeries, FEEDBACK_PASS, SLOPE_SPAN, TABLE_BYTES,
    TABLE_MAGIC, TABLE_VERSION,
};
use friction::FrictionAdapt;

/// Loads in the feed-forward's schedule.
pub const DESIGNED_POINTS: usize = 9;
/// The reference's rate at which the friction compensation is whole, g/s (below it, in
/// proportion: a hold gets none, and the compensation does not chatter about it).
pub const FRICTION_RATE_G_PER_S: f32 = 20.0;
/// How far the reading lags the reference computed at the same tick, ticks: the gauge's
/// reading is the mean of the period that ends at the tick, and the feed-forward puts the
/// contact force on the reference at the tick. Measured on the simulated rigs (a sine's
/// reading over the reference of the tick, no friction, the feed-forward alone): 0.2–0.5 at
/// 10–40 Hz. The two ticks compared before put 0.5 dB of spurious feedback into the memo
/// rig's 10 Hz and about as much again at 40 Hz on a rig of fast amplifier.
pub const READING_LAG_TICKS: f32 = 0.5;
/// The friction compensation's adaptation (see `FrictionAdapt`): the share of each
/// reversal's measured shortfall taken, the most one reversal may move it (a share of the
/// identified stiction), and its range (shares of the identified stiction).
pub const ADAPT_GAIN: f32 = 0.3;
pub const ADAPT_STEP_SHARE: f32 = 0.05;
pub const ADAPT_RANGE: (f32, f32) = (0.5, 1.5);
/// Reversals it learns from: a swing since the last one within this many times the stiction,
/// and a move within the window of at least this share of it.
pub const ADAPT_SWING_SHARE: f32 = 6.0;
pub const ADAPT_MOTION_SHARE: f32 = 0.2;
/// Ticks of each half of a touch-down pulse (push, then brake).
pub const APPROACH_TICKS: u16 = 10;
/// The pulses' shape over their [`APPROACH_TICKS`] ticks: sin²(π(k + ½)/10), a Hann window
/// (its mean is ½). A square pulse's edges ring the free beam (±1.2 g on the memo rig, damped
/// over 0.1 s), which the contact test would have to see through.
pub const APPROACH_SHAPE: [f32; APPROACH_TICKS as usize] = [
    0.024471742,
    0.206_107_38,
    0.5,
    0.7938926,
    0.97552826,
    0.97552826,
    0.7938926,
    0.5,
    0.206_107_38,
    0.024471742,
];
/// Readings the contact test looks at, and how many of them must reach `contact_g`: the free
/// beam rings at the pulses' edges (±1.2 g on the memo rig, slowly damped) about the tip's
/// inertia, and a ringing reading spends under half its time above a small threshold; on the
/// finger the force stays there.
pub const CONTACT_TICKS: usize = 8;
pub const CONTACT_COUNT: usize = 6;
/// Readings of one pulse cycle (push and brake): their mean is the other contact test, at
/// [`CONTACT_MEAN_SHARE`] of `contact_g`. In flight the gauge reads the tip's inertia, which
/// over a whole cycle of a probe that stops each cycle means nothing; pressed on the finger
/// it reads the cycle's mean drive less the friction. Where the friction is light, the brake
/// pulls the probe back between pushes and no reading stays at `contact_g`: with a quarter of
/// the memo rig's stiction, a probe at rest on the finger read 0.16–0.30 g under the pulses
/// and never counted as landed.
pub const CYCLE_TICKS: usize = 2 * APPROACH_TICKS as usize;
/// The cycle's mean reading that also means contact, as a share of `contact_g` (0.2 g of the
/// design's 0.4 g: six deviations of a 20-reading mean of the gauge's 0.14 g noise).
pub const CONTACT_MEAN_SHARE: f32 = 0.5;
/// A command that leaves rest (after a touch-down, or from zero with the probe held on the
/// finger) ramps up at this rate, g/s, plus the force reached over [`TOUCH_TAU_S`] (a ramp
/// that grows as the finger stiffens: 150 g/s at 10 g, 550 g/s at 50 g) until it meets the
/// command. The reference's acceleration at the start of a step meets the lightest loads'
/// inverse, the largest (their mode is the lowest): at the protocols' 500 g/s, a step from rest
/// on the memo rig was a drive spike of about 25 g and landed 1.4–2.5 g over. A command that
/// moves about a load (a sine about 10 g) is not ramped.
pub const TOUCH_RATE_G_PER_S: f32 = 50.0;
pub const TOUCH_TAU_S: f32 = 0.1;

/// One tick of the reference model, precomputed: e^(−ω·dt) and ω.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Reference {
    w: f32,
    decay: f32,
    dt_s: f32,
}

impl Reference {
    /// Advances (y, y', y'') over one tick with the input ramping from `r0` to `r1` (a
    /// first-order hold, one tick late: a held input's steps alias into the derivatives the
    /// feed-forward uses; measured, y'' of a 40 Hz sine came out 15 % low with a hold).
    /// Under a ramp r(t) = r0 + vt a triple pole at −ω follows r − 3v/ω, and the error from
    /// that is e^(−ωt)(a + bt + ct²), whose constants the state gives.
    #[inline]
    fn step(&self, x: &mut [f32; 3], r0: f32, r1: f32) {
        let (w, t) = (self.w, self.dt_s);
        let v = (r1 - r0) / t;
        let a = x[0] - (r0 - 3.0 * v / w);
        let b = x[1] - v + w * a;
        let c = 0.5 * (x[2] - w * w * a + 2.0 * w * b);
        let p = a + (b + c * t) * t;
        let dp = b + 2.0 * c * t;
        let ddp = 2.0 * c;
        *x = [
            r1 - 3.0 * v / w + self.decay * p,
            v + self.decay * (dp - w * p),
            self.decay * (ddp - 2.0 * w * dp + w * w * p),
        ];
    }
}

/// The controller's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesignedController {
    config: DesignedConfig,
    reference: Reference,
    /// (y, y', y'') of the reference model.
    x: [f32; 3],
    /// y'' one and two ticks ago (y''' is their second-order backward difference with y'').
    past_y2: [f32; 2],
    /// The last command (where this tick's input ramp starts).
    last_command_g: f32,
    /// Last tick's Coulomb compensation, g, before the amplifier's (1 + τs).
    coulomb_g: f32,
    integral_g: f32,
    /// The feedback biquad's state (transposed direct form II).
    filter_state: [f32; 2],
    /// On the finger (force control) or touching down.
    landed: bool,
    /// The tick within the current pulse (push, then brake), 0 to 2·[`APPROACH_TICKS`] − 1.
    approach_tick: u16,
    /// The last [`CYCLE_TICKS`] readings, for the contact tests.
    recent_g: [f32; CYCLE_TICKS],
    recent_head: usize,
    /// Readings taken since the last lift, up to [`CYCLE_TICKS`] (the cycle's mean is only a
    /// test once it spans a whole cycle: the push's half alone reads the tip's inertia).
    readings: u8,
    /// The most the command may be while it ramps up from rest, g, and whether it is.
    ramp_g: f32,
    ramping: bool,
    /// The direction the reference last moved (−1, 0 before any move, 1).
    moved: f32,
    /// Ticks the reference has been still (its rate under a tenth of the friction's), up to
    /// [`REST_TICKS`].
    still_ticks: u8,
    adapt: FrictionAdapt,
}

/// A rest drives nothing once the reference is under this share of `contact_g`.
pub const REST_SHARE: f32 = 0.1;

/// Ticks the reference must be still before a move counts as one from rest (20 ms: a sine's
/// reversal is not a rest).
pub const REST_TICKS: u8 = 20;

/// What the newest readings say of the contact.
struct Contact {
    /// How many of the newest [`CONTACT_TICKS`] are at contact.
    above: usize,
    /// Whether they read the finger unloaded.
    unloaded: bool,
}

/// What one tick of the controller decided, besides the drive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesignedOutput {
    pub drive: Adjusted,
    /// The reference force this tick, g.
    pub reference_g: f32,
}

impl DesignedController {
    pub fn new(config: DesignedConfig) -> Result<Self, DesignedError> {
        config.check()?;
        // f32 throughout: an f64 exp is 2 KB of soft float on the Cortex-M4F.
        let w = 2.0 * core::f32::consts::PI * config.reference_hz;
        let mut t = Self {
            reference: Reference {
                w,
                decay: libm::expf(-w * config.dt_s),
                dt_s: config.dt_s,
            },
            config,
            x: [0.0; 3],
            past_y2: [0.0; 2],
            last_command_g: 0.0,
            coulomb_g: 0.0,
            integral_g: 0.0,
            moved: 0.0,
            still_ticks: 0,
            filter_state: [0.0; 2],
            landed: false,
            approach_tick: 0,
            recent_g: [0.0; CYCLE_TICKS],
            recent_head: 0,
            readings: 0,
            ramp_g: 0.0,
            ramping: false,
            adapt: FrictionAdapt::new(config.friction_g),
        };
        t.lift();
        Ok(t)
    }

    pub fn config(&self) -> &DesignedConfig {
        &self.config
    }

    /// Back to rest (the safe output's restart).
    pub fn reset(&mut self) {
        self.x = [0.0; 3];
        self.past_y2 = [0.0; 2];
        self.last_command_g = 0.0;
        self.coulomb_g = 0.0;
        self.integral_g = 0.0;
        self.filter_state = [0.0; 2];
        self.adapt.cancel();
        self.lift();
    }

    /// The probe may be off the finger (start, safe output, contact lost): the next command
    /// touches down.
    pub fn lift(&mut self) {
        // A table without a contact force has no touch-down (a plant that is always in
        // contact, as the unit plant of the tests).
        self.landed = self.config.contact_g <= 0.0;
        self.approach_tick = 0;
        self.recent_g = [0.0; CYCLE_TICKS];
        self.readings = 0;
    }

    /// On the finger, under force control.
    pub fn landed(&self) -> bool {
        self.landed
    }

    /// Touching down: off the finger, or on it with the command ramping up from rest.
    pub fn touching_down(&self) -> bool {
        !self.landed || self.ramping
    }

    /// Starts the reference from `force_g` at rest (after a re-approach: from where the force
    /// is, as the slew limiter does).
    pub fn restart_from(&mut self, force_g: f32) {
        if force_g.is_finite() {
            self.x = [force_g, 0.0, 0.0];
            self.past_y2 = [0.0; 2];
            self.last_command_g = force_g;
            self.coulomb_g = 0.0;
            self.filter_state = [0.0; 2];
            self.moved = 0.0;
            self.still_ticks = 0;
            self.adapt.cancel();
        }
    }

    /// One tick: `command_g` the shaped command, `sensed_g` the gauge force of the last tick;
    /// `integrate` false holds the integral (re-approach).
    #[inline]
    pub fn update(&mut self, command_g: f32, sensed_g: f32, integrate: bool) -> Adjusted {
        self.tick(command_g, sensed_g, integrate).drive
    }

    /// [`Self::update`] with the reference force.
    pub fn tick(&mut self, command_g: f32, sensed_g: f32, integrate: bool) -> DesignedOutput {
        if !command_g.is_finite() || !sensed_g.is_finite() {
            return DesignedOutput {
                drive: Adjusted {
                    force_g: 0.0,
                    saturated: false,
                    invalid_input: true,
                },
                reference_g: self.x[0],
            };
        }
        let contact = self.watch_contact(command_g, sensed_g);
        if !self.landed && !self.lands(command_g, sensed_g, &contact) {
            return self.touch_down(command_g, sensed_g);
        }
        let (command_g, rest) = self.ramped(command_g);
        let third = self.advance_reference(command_g);
        let point = self.config.point_at(self.x[0]);
        let friction = self.friction_g(&point.c);
        let feed_forward = self.feed_forward_g(&point.c, third, friction);
        // NOTE: a rest (a command at or below zero) drives nothing once the reference is under
        // a tenth of contact and the gauge reads the finger unloaded: the held friction and the
        // integral have no finger to push against, and on a heavy rig their sum (1.6 g against
        // 1.1 g of stiction) threw the probe 9.5 mm off, where the next touch-down took seconds
        // to come back from.
        let resting = rest && self.x[0] < REST_SHARE * self.config.contact_g && contact.unloaded;
        self.feedback(&point, feed_forward, sensed_g, integrate, resting)
    }

    /// The reading kept; how many of the newest are at contact and whether they read the
    /// finger unloaded; a landed probe commanded to rest and unloaded lifts.
    fn watch_contact(&mut self, command_g: f32, sensed_g: f32) -> Contact {
        if let Some(slot) = self.recent_g.get_mut(self.recent_head) {
            *slot = sensed_g;
        }
        self.recent_head = (self.recent_head + 1) % CYCLE_TICKS;
        self.readings = self.readings.saturating_add(1).min(CYCLE_TICKS as u8);
        let contact_g = self.config.contact_g;
        // The newest CONTACT_TICKS readings are the ones just before the head.
        let newest = (1..=CONTACT_TICKS).filter_map(|k| {
            self.recent_g
                .get((self.recent_head + CYCLE_TICKS - k) % CYCLE_TICKS)
        });
        let above = newest.clone().filter(|v| **v >= contact_g).count();
        // NOTE: a rest ends when the gauge reads the finger unloaded, not when the reference
        // does: at the end of the unloading ramp the motor sticks, and a drive of zero there
        // left a finger pressed at 0.85 g through a rest (the next 4 g touch-down landed
        // 2.3 g over on a rig of 28 g/V); the loop pulls on until the reading is down.
        let unloaded = newest.sum::<f32>() < CONTACT_MEAN_SHARE * contact_g * CONTACT_TICKS as f32;
        if self.landed && command_g <= 0.0 && above == 0 && unloaded {
            self.lift();
        }
        Contact { above, unloaded }
    }

    /// Whether a probe off the finger lands this tick (force control then starts).
    fn lands(&mut self, command_g: f32, sensed_g: f32, contact: &Contact) -> bool {
        let (above, contact_g) = (contact.above, self.config.contact_g);
        // The cycle's mean, once the readings since the lift span a whole cycle.
        let cycle_mean_g = (usize::from(self.readings) >= CYCLE_TICKS)
            .then(|| self.recent_g.iter().sum::<f32>() / CYCLE_TICKS as f32);
        let pressed = cycle_mean_g.is_some_and(|m| m >= CONTACT_MEAN_SHARE * contact_g);
        if command_g > 0.0 && (above >= CONTACT_COUNT || pressed) {
            // Force control from the cycle's mean reading (the last reading rings with the
            // free beam: the slow-amplifier rig landed reading 1.06 g on 0.21 g, and the
            // reference's 0.85 g head start pushed the motor to 3.1 g, where it stuck),
            // the command ramping up from it.
            let from_g = cycle_mean_g.unwrap_or(sensed_g);
            self.landed = true;
            self.restart_from(from_g);
            self.ramp_g = from_g;
            self.ramping = true;
            return true;
        }
        false
    }

    /// The command the reference follows, and whether it is a rest: a rest unloads down a
    /// ramp; a load rises along one from a touch-down or from rest until it meets the command.
    fn ramped(&mut self, mut command_g: f32) -> (f32, bool) {
        let contact_g = self.config.contact_g;
        // NOTE: a rest unloads the finger down the touch-down's ramp reversed: the probe leaves
        // the finger at the speed the force falls over the finger's stiffness, which at the
        // lightest loads is the least; at the supervisor's 500 g/s the probe flew off (0.45 mm
        // on a rig of stiffer beam, whose next 4 g touch-down took 0.43 s).
        let rest = command_g <= 0.0 && contact_g > 0.0;
        if rest && self.ramp_g > 0.0 {
            let rate = TOUCH_RATE_G_PER_S + self.ramp_g / TOUCH_TAU_S;
            let next_g = (self.ramp_g - rate * self.config.dt_s).max(0.0);
            // NOTE: the integral fades with the ramp: what it carries is the model's error at
            // this load, which goes with the load, and where in its friction band the motor
            // stuck, which a finger unloaded has no use for. Whole, it pulled: a 4 g hold on
            // an unseen rig (`random-applicators.py 2026`, r3) wound −2.6 g (the motor pulled
            // back across its band while the held share assumed it stuck at the top), which
            // with the friction's −2.1 g threw the probe off the finger at 20 mm/s, 0.43 mm.
            self.integral_g *= next_g / self.ramp_g;
            self.ramp_g = next_g;
            command_g = self.ramp_g;
        }
        // A ramp starts at a touch-down or as the command leaves rest, and runs until it
        // meets the command.
        self.ramping =
            (self.ramping || self.ramp_g <= 0.0) && command_g > self.ramp_g && contact_g > 0.0;
        if self.ramping {
            let rate = TOUCH_RATE_G_PER_S + self.ramp_g.max(0.0) / TOUCH_TAU_S;
            self.ramp_g += rate * self.config.dt_s;
            command_g = command_g.min(self.ramp_g);
        } else {
            self.ramp_g = command_g;
        }
        (command_g, rest)
    }

    /// The reference advanced to `command_g`; its third derivative.
    fn advance_reference(&mut self, command_g: f32) -> f32 {
        let c = &self.config;
        self.reference
            .step(&mut self.x, self.last_command_g, command_g);
        self.last_command_g = command_g;
        // NOTE: y''' from y'' over the last two ticks, not from the state: with the reference's
        // time constant under a tick (0.8 ms) y''' swings within each tick at the input's kinks,
        // and its value at the tick's end was 1.3 dB low and 37° ahead at 40 Hz (+7.5 dB, 73°
        // at 10 Hz), which put the memo rig's feed-forward alone +1.3 dB at 40 Hz about 50 g on
        // a plant without friction. The backward difference is within 0.2 dB and 0.3° to 40 Hz.
        let [y2_1, y2_2] = self.past_y2;
        let third = (3.0 * self.x[2] - 4.0 * y2_1 + y2_2) / (2.0 * c.dt_s);
        self.past_y2 = [self.x[2], y2_1];
        third
    }

    /// The friction's compensation at the reference's rate, the integral's share against the
    /// friction dropped where the motor turns or starts.
    fn friction_g(&mut self, k: &[f32; 4]) -> f32 {
        let c = &self.config;
        let rate = self.x[1] / FRICTION_RATE_G_PER_S;
        if rate.abs() >= 0.5 {
            let now = rate.signum();
            let reversal = self.moved != 0.0 && now != self.moved;
            let from_rest = self.still_ticks >= REST_TICKS;
            // NOTE: at rest the motor stuck anywhere in its band, ± the stiction about the
            // drive the force needs, and the integral wound what the held share got wrong of
            // that; once it slides the friction is the whole stiction along the move, which the
            // compensation gives, so what the integral holds along the move within the band
            // less the held share is friction, and dropped, whichever way it pushes. A step
            // that overshot and was pulled back across the band carried it with the next step
            // the other way (a 0.6x drive's 100 -> 90 g step went 1.4 g under and stuck 50 ms).
            // A reversal without a rest (a sine's turn) slid throughout: only what the integral
            // carried against the new direction, up to the held share.
            let along = if from_rest {
                // (The band's ends past zero: only what the integral holds is dropped.)
                let held = c.held_friction_g * self.moved * now;
                let (lo, hi) = (-c.friction_g - held, c.friction_g - held);
                crate::limit(self.integral_g * now, lo.min(0.0), hi.max(0.0))
            } else if reversal {
                crate::limit(self.integral_g * now, -c.held_friction_g, 0.0)
            } else {
                0.0
            };
            self.integral_g -= along * now;
            if reversal {
                self.adapt.reversal(now, self.x[0], k, c);
            }
            self.moved = now;
            self.still_ticks = 0;
        } else if rate.abs() < 0.1 {
            self.still_ticks = self.still_ticks.saturating_add(1).min(REST_TICKS);
        }
        let still = (1.0 - 2.0 * rate.abs()).max(0.0);
        // NOTE: the compensation reaches the motor through the amplifier, so where its sign
        // turns it passes the amplifier's inverse: a tick of τ/dt times the turn, then the step.
        let coulomb_g = self.adapt.friction_g * crate::limit(rate, -1.0, 1.0);
        let turning = if coulomb_g * self.coulomb_g < 0.0 {
            c.amplifier_tau_s / c.dt_s * (coulomb_g - self.coulomb_g)
        } else {
            0.0
        };
        let friction = coulomb_g + turning + c.held_friction_g * still * self.moved;
        self.coulomb_g = coulomb_g;
        friction
    }

    /// The drive that makes the identified plant follow the reference.
    fn feed_forward_g(&self, k: &[f32; 4], third: f32, friction: f32) -> f32 {
        let c = &self.config;
        // NOTE: the contact stiffens with load, so the force's rate itself takes drive: a mass
        // on a spring F(x) needs m·ẍ = m·(F''/k − k'·F'²/k²), whose second part is
        // dc₂/dF·F'² (c₂ = m/k). Without it a 6 g sine about 10 g at 40 Hz rang +2…+3 dB on
        // every rig (its force's rate 1.5 kg/s).
        let stiffening = c.c2_slope_at(self.x[0]) * self.x[1] * self.x[1];
        k[0] * self.x[0]
            + k[1] * self.x[1]
            + k[2] * self.x[2]
            + k[3] * third
            + stiffening
            + friction
    }

    /// The feedback on the error against the reading the reference predicts, the integral
    /// wound where the drive is not pushing out of its range, and the drive.
    fn feedback(
        &mut self,
        point: &InverseSeries,
        feed_forward: f32,
        sensed_g: f32,
        integrate: bool,
        resting: bool,
    ) -> DesignedOutput {
        let c = &self.config;
        let (k, share) = (point.c, point.feedback);
        let (kp, ki) = (share * c.kp, share * c.ki_per_s);
        // The reading the reference predicts: the period's mean, and the tip's inertia.
        let expected_g =
            self.x[0] - READING_LAG_TICKS * c.dt_s * self.x[1] + point.gauge_s2 * self.x[2];
        let [b0, b1, b2, a1, a2] = c.feedback_filter;
        let x = expected_g - sensed_g;
        if integrate {
            self.adapt.observe(x, expected_g, c, k[0]);
        }
        let error_g = b0 * x + self.filter_state[0];
        self.filter_state = [
            b1 * x - a1 * error_g + self.filter_state[1],
            b2 * x - a2 * error_g,
        ];
        let raw_without = feed_forward + kp * error_g + self.integral_g;
        let pushing_out = (raw_without >= c.drive_max_g && error_g > 0.0)
            || (raw_without <= c.drive_min_g && error_g < 0.0);
        if integrate && !pushing_out && !resting {
            self.integral_g = crate::limit(
                self.integral_g + ki * c.dt_s * error_g,
                -c.integral_limit_g,
                c.integral_limit_g,
            );
        }
        let raw = if resting {
            0.0
        } else {
            feed_forward + kp * error_g + self.integral_g
        };
        let force_g = crate::limit(raw, c.drive_min_g, c.drive_max_g);
        DesignedOutput {
            drive: Adjusted {
                force_g,
                saturated: force_g != raw,
                invalid_input: false,
            },
            reference_g: self.x[0],
        }
    }

    /// A tick off the finger: at rest for a command at or below zero, else the next step of
    /// the pulse train. The reference waits at the reading.
    fn touch_down(&mut self, command_g: f32, sensed_g: f32) -> DesignedOutput {
        let c = &self.config;
        let force_g = if command_g > 0.0 {
            let phase = self.approach_tick;
            self.approach_tick = (phase + 1) % (2 * APPROACH_TICKS);
            let shape = APPROACH_SHAPE
                .get(usize::from(phase % APPROACH_TICKS))
                .copied()
                .unwrap_or(0.0);
            if phase >= APPROACH_TICKS {
                shape * c.approach_brake_g
            } else {
                c.approach_hold_g + shape * c.approach_push_g
            }
        } else {
            self.approach_tick = 0;
            0.0
        };
        self.x = [sensed_g, 0.0, 0.0];
        self.past_y2 = [0.0; 2];
        self.last_command_g = sensed_g;
        let force_g = crate::limit(force_g, c.drive_min_g, c.drive_max_g);
        DesignedOutput {
            drive: Adjusted {
                force_g,
                saturated: false,
                invalid_input: false,
            },
            reference_g: sensed_g,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_model_is_a_triple_pole_with_unit_gain() {
        // A ramp vt through 1/(1 + s/ω)³: v(t − 3/ω + e^(−ωt)(3/ω + 2t + ωt²/2)), its slope
        // v(1 − e^(−ωt)(1 + ωt + (ωt)²/2)); the commands are the ramp's samples.
        let cfg = DesignedConfig::UNIT_PLANT;
        let mut t = DesignedController::new(cfg).unwrap();
        let w = 2.0 * std::f64::consts::PI * f64::from(cfg.reference_hz);
        let v = 100.0;
        for k in 1..=30 {
            let time = k as f64 * 1e-3;
            t.tick((v * time) as f32, 0.0, false);
            let e = (-w * time).exp();
            let y = v * (time - 3.0 / w + e * (3.0 / w + 2.0 * time + w * time * time / 2.0));
            let wt = w * time;
            let slope = v * (1.0 - e * (1.0 + wt + wt * wt / 2.0));
            assert!(
                (f64::from(t.x[0]) - y).abs() < 1e-4,
                "tick {k}: {} vs {y}",
                t.x[0]
            );
            assert!(
                (f64::from(t.x[1]) - slope).abs() < 1e-3 * v,
                "tick {k}: {} vs {slope}",
                t.x[1]
            );
        }
    }

    #[test]
    fn the_reference_model_differentiates_a_sine_without_aliasing() {
        // In steady state y'' = −ω²y for a sine: at 40 Hz within 2 %, the feed-forward's
        // second-order term depends on it (with a held input it came out 15 % low).
        let mut t = DesignedController::new(DesignedConfig::UNIT_PLANT).unwrap();
        let w = 2.0 * std::f64::consts::PI * 40.0;
        let (mut y_amp, mut y2_amp) = (0.0f64, 0.0f64);
        for k in 0..2000 {
            t.tick((w * k as f64 * 1e-3).sin() as f32, 0.0, false);
            if k > 1000 {
                y_amp = y_amp.max(f64::from(t.x[0]).abs());
                y2_amp = y2_amp.max(f64::from(t.x[2]).abs());
            }
        }
        let ratio = y2_amp / (w * w * y_amp);
        assert!((ratio - 1.0).abs() < 0.02, "{ratio}");
    }

    #[test]
    fn the_third_derivative_is_the_seconds_rate_at_every_band_frequency() {
        // The feed-forward's s³ term against jω times the reference's y'' (a sine's phasors,
        // locked in over whole periods): within 0.3 dB and 1° from 10 to 40 Hz (the model's
        // y''' at the tick's end was +7.5 dB, 73° off at 10 Hz and −1.3 dB, 37° at 40 Hz).
        for hz in [10.0f64, 20.0, 40.0] {
            let c3 = 1e-8f32;
            let mut cfg = DesignedConfig::UNIT_PLANT;
            for p in cfg.schedule.iter_mut() {
                p.c = [1.0, 0.0, 0.0, c3];
            }
            cfg.kp = 0.0;
            cfg.ki_per_s = 0.0;
            let mut t = DesignedController::new(cfg).unwrap();
            let w = 2.0 * std::f64::consts::PI * hz;
            let (mut third, mut second) = ((0.0f64, 0.0f64), (0.0f64, 0.0f64));
            for k in 0..3000 {
                let phase = w * k as f64 * 1e-3;
                let out = t.tick((10.0 + phase.sin()) as f32, 10.0, false);
                if k >= 1000 {
                    let y3 = f64::from((out.drive.force_g - t.x[0]) / c3);
                    let y2 = f64::from(t.x[2]);
                    third = (third.0 + y3 * phase.cos(), third.1 - y3 * phase.sin());
                    second = (second.0 + y2 * phase.cos(), second.1 - y2 * phase.sin());
                }
            }
            // jω·Y2
            let ideal = (-w * second.1, w * second.0);
            let db = 20.0 * (third.0.hypot(third.1) / ideal.0.hypot(ideal.1)).log10();
            let deg = (third.1.atan2(third.0) - ideal.1.atan2(ideal.0)).to_degrees();
            let deg = (deg + 540.0) % 360.0 - 180.0;
            assert!(
                db.abs() < 0.3 && deg.abs() < 1.0,
                "{hz} Hz: {db} dB, {deg}°"
            );
        }
    }

    #[test]
    fn the_feed_forward_is_the_series_on_the_references_derivatives() {
        // c = (2, 0.01, 0, 0): on a ramp the reference's slope is the ramp's, so the drive is
        // 2·y + 0.01·slope once the model has caught up (integral off).
        let mut cfg = DesignedConfig::UNIT_PLANT;
        cfg.schedule[0].c = [2.0, 0.01, 0.0, 0.0];
        cfg.ki_per_s = 0.0;
        let mut t = DesignedController::new(cfg).unwrap();
        let mut last = None;
        for k in 0..100 {
            let r = 0.1 * k as f32; // 100 g/s
            last = Some(t.tick(r, 0.0, true));
        }
        let out = last.unwrap();
        let expected = 2.0 * out.reference_g + 0.01 * 100.0;
        assert!(
            (out.drive.force_g - expected).abs() < 1e-2,
            "{out:?} vs {expected}"
        );
    }

    #[test]
    fn the_schedule_interpolates_between_loads_and_holds_its_ends() {
        let mut cfg = DesignedConfig::UNIT_PLANT;
        cfg.points = 2;
        cfg.schedule[0] = InverseSeries {
            load_g: 10.0,
            c: [1.0, 2.0, 3.0, 4.0],
            feedback: 0.5,
            gauge_s2: 1e-5,
        };
        cfg.schedule[1] = InverseSeries {
            load_g: 50.0,
            c: [2.0, 4.0, 6.0, 8.0],
            feedback: 1.0,
            gauge_s2: 3e-5,
        };
        assert_eq!(cfg.series_at(5.0), ([1.0, 2.0, 3.0, 4.0], 0.25));
        for (load_g, gauge_s2) in [(5.0, 1e-5), (30.0, 2e-5), (90.0, 3e-5)] {
            assert!(
                (cfg.point_at(load_g).gauge_s2 - gauge_s2).abs() < 1e-9,
                "{load_g}"
            );
        }
        assert_eq!(cfg.series_at(0.0), ([1.0, 2.0, 3.0, 4.0], 0.0));
        assert_eq!(cfg.series_at(30.0), ([1.5, 3.0, 4.5, 6.0], 0.75));
        assert_eq!(cfg.series_at(90.0), ([2.0, 4.0, 6.0, 8.0], 1.0));
        // c₂'s slope, by hand: the line's 3/40 s²/g where both ends of the difference
        // (a quarter of the load either side) are on it; none where both are held; at 60 g
        // from 45 g (3 + 35/40·3) to 75 g (held at 6): 0.375/30.
        for (load_g, slope) in [(30.0, 0.075), (8.0, 0.0), (60.0, 0.0125), (100.0, 0.0)] {
            assert!((cfg.c2_slope_at(load_g) - slope).abs() < 1e-6, "{load_g}");
        }
    }

    #[test]
    fn a_bad_configuration_names_its_parameter() {
        let mut cfg = DesignedConfig::UNIT_PLANT;
        cfg.ki_per_s = f32::NAN;
        assert_eq!(
            DesignedController::new(cfg).unwrap_err(),
            DesignedError::Invalid("ki_per_s")
        );
        let mut cfg = DesignedConfig::UNIT_PLANT;
        cfg.points = 2;
        cfg.schedule[1].load_g = -1.0;
        assert_eq!(
            DesignedController::new(cfg).unwrap_err(),
            DesignedError::ScheduleOrder
        );
        let mut cfg = DesignedConfig::UNIT_PLANT;
        cfg.schedule[0].gauge_s2 = f32::INFINITY;
        assert_eq!(
            DesignedController::new(cfg).unwrap_err(),
            DesignedError::Invalid("schedule")
        );
    }

    #[test]
    fn the_integral_removes_a_plant_gain_error_and_holds_when_told() {
        // The plant gives 0.8 of its drive; the feed-forward assumes 1.
        let mut t = DesignedController::new(DesignedConfig::UNIT_PLANT).unwrap();
        let mut sensed = 0.0;
        for _ in 0..1000 {
            sensed = 0.8 * t.update(20.0, sensed, true).force_g;
        }
        assert!((sensed - 20.0).abs() < 0.01, "{sensed}");
        let held = t.integral_g;
        t.update(20.0, 0.0, false);
        assert_eq!(t.integral_g, held);
    }

    #[test]
    fn the_approach_shape_is_a_hann_window_of_mean_one_half() {
        for (k, v) in APPROACH_SHAPE.iter().enumerate() {
            let x = (core::f32::consts::PI * (k as f32 + 0.5) / 10.0).sin();
            assert!((v - x * x).abs() < 1e-6, "{k}: {v}");
        }
        let mean = APPROACH_SHAPE.iter().sum::<f32>() / APPROACH_SHAPE.len() as f32;
        assert!((mean - 0.5).abs() < 1e-6, "{mean}");
    }

    #[test]
    fn off_the_finger_it_pulses_lands_on_contact_and_ramps_up_from_the_cycles_mean() {
        let mut cfg = DesignedConfig::UNIT_PLANT;
        cfg.approach_hold_g = 1.0;
        cfg.approach_push_g = 0.8;
        cfg.approach_brake_g = -0.4;
        cfg.contact_g = 0.4;
        let mut t = DesignedController::new(cfg).unwrap();
        assert!(!t.landed() && t.touching_down());
        // At rest (no command) there is no drive.
        assert_eq!(t.update(0.0, 0.0, true).force_g, 0.0);
        // A command: ten ticks of push on the stiction, ten of brake, and again.
        let drives: Vec<f32> = (0..40).map(|_| t.update(5.0, 0.0, true).force_g).collect();
        for (k, d) in drives.iter().enumerate() {
            let shape = APPROACH_SHAPE[k % 10];
            let expected = if k % 20 < 10 {
                1.0 + 0.8 * shape
            } else {
                -0.4 * shape
            };
            assert!((d - expected).abs() < 1e-6, "tick {k}: {d} vs {expected}");
        }
        // Readings at the contact force: a ringing beam's (half the time above) does not land
        // it, six of eight do.
        for k in 0..16 {
            t.update(5.0, if k % 2 == 0 { 0.9 } else { -0.9 }, true);
            assert!(!t.landed(), "ringing landed it at {k}");
        }
        for _ in 0..8 {
            t.update(5.0, 0.0, true);
        }
        for _ in 0..5 {
            t.update(5.0, 0.5, true);
            assert!(!t.landed());
        }
        t.update(5.0, 0.5, true);
        assert!(t.landed() && t.touching_down());
        // From the last cycle's mean reading (six of 0.5 g, eight of none, six ringing about
        // none: 0.15 g), the reference follows a command ramping up as
        // r' = TOUCH_RATE_G_PER_S + r/TOUCH_TAU_S (per tick, r ← r + dt·(a + r/τ)).
        let (a, tau) = (TOUCH_RATE_G_PER_S * 1e-3, TOUCH_TAU_S * 1e3);
        let ramp_g = |ticks: i32| (0..ticks).fold(0.15f32, |r, _| r + a + r / tau);
        let mut last = 0.0;
        for k in 1..=200 {
            last = t.tick(5.0, 0.5, false).reference_g;
            if k == 10 {
                // Ten ticks: 0.15·1.01¹⁰ + 0.05·(1.01¹⁰ − 1)/0.01 = 0.1657 + 0.5231 g.
                assert!((ramp_g(10) - 0.6888).abs() < 1e-3, "{}", ramp_g(10));
                assert!(last < ramp_g(10) && last > ramp_g(10) - 0.3, "{last}");
            }
        }
        assert!((last - 5.0).abs() < 1e-3, "{last}");
        assert!(!t.touching_down());
        // Back to no command: once no reading is at the contact force, the next command
        // touches down again.
        t.update(0.0, 0.3, true);
        assert!(t.landed());
        for _ in 0..8 {
            t.update(0.0, 0.1, true);
        }
        assert!(!t.landed());
    }

    #[test]
    fn a_pulse_cycles_mean_reading_lands_a_probe_the_brake_pulls_back() {
        let mut cfg = DesignedConfig::UNIT_PLANT;
        cfg.approach_push_g = 0.8;
        cfg.approach_brake_g = -0.4;
        cfg.contact_g = 0.4;
        // On the finger with little friction the reading follows the pulses about a small
        // mean and never stays at the contact force: 0.15 g ± 0.2 g is under half of it.
        let reading = |k: usize, mean_g: f32| {
            mean_g + 0.2 * (2.0 * core::f32::consts::PI * k as f32 / CYCLE_TICKS as f32).sin()
        };
        let mut t = DesignedController::new(cfg).unwrap();
        for k in 0..200 {
            t.update(5.0, reading(k, 0.15), true);
            assert!(!t.landed(), "0.15 g landed at tick {k}");
        }
        // 0.25 g ± 0.2 g (the quarter-stiction memo rig's 0.16–0.30 g): six of eight never
        // reach 0.4 g, the cycle's mean does, from the first whole cycle on.
        let mut t = DesignedController::new(cfg).unwrap();
        let landed_at = (0..200).find(|&k| {
            t.update(5.0, reading(k, 0.25), true);
            t.landed()
        });
        assert!(
            landed_at.is_some_and(|k| k + 1 >= CYCLE_TICKS && k < 2 * CYCLE_TICKS),
            "{landed_at:?}"
        );
        // Force control starts from the cycle's mean, not the last reading.
        let reference_g = t.tick(5.0, 0.25, true).reference_g;
        assert!((reference_g - 0.25).abs() < 0.1, "{reference_g}");
    }

    /// One reversal's window of `FrictionAdapt` on a reference that ramps down by 0.2 g a
    /// tick from 12 g (a sine's turn, straightened) and a reading `reading(k)`; the friction
    /// after it (the identified 1 g; the window of a 35 Hz mode, 14 ticks).
    fn adapted_after_one_reversal(reading: impl Fn(f32) -> f32) -> f32 {
        let config = DesignedConfig {
            friction_g: 1.0,
            ..DesignedConfig::UNIT_PLANT
        };
        let mut a = FrictionAdapt::new(1.0);
        // c₀ = 1, c₂ = 1/ω² of a 35.7 Hz mode: a half period of 14 ms.
        let c = [
            1.0,
            0.0,
            1.0 / (2.0 * core::f32::consts::PI * 35.7f32).powi(2),
            0.0,
        ];
        a.since_reversal = 100;
        a.last_reversal_g = 8.0;
        a.reversal(-1.0, 12.0, &c, &config);
        assert_eq!(a.length, 14);
        for k in 0..20 {
            let reference = 12.0 - 0.2 * k as f32;
            a.observe(reference - reading(k as f32), reference, &config, 1.0);
        }
        a.friction_g
    }

    #[test]
    fn the_friction_compensation_grows_where_the_motor_sticks_and_shrinks_where_it_runs_ahead() {
        // A reading that follows the reference: nothing to learn.
        assert_eq!(adapted_after_one_reversal(|k| 12.0 - 0.2 * k), 1.0);
        // Stuck at 12 g while the reference falls 2.8 g: short by far more than one step may
        // take, so one step, 5 % of the identified stiction.
        let stuck = adapted_after_one_reversal(|_| 12.0);
        assert!((stuck - 1.05).abs() < 1e-6, "{stuck}");
        // Running ahead by a fifth of the reference's move: the weighted fit reads 0.2 of the
        // move (the move's smoothstep-weighted mean over its weight²), times the gain 0.3.
        let ahead = adapted_after_one_reversal(|k| 12.0 - 0.24 * k);
        assert!((0.95..1.0).contains(&ahead), "{ahead}");
        // A swing since the last reversal of more than six stictions opens no window.
        let config = DesignedConfig {
            friction_g: 1.0,
            ..DesignedConfig::UNIT_PLANT
        };
        let mut a = FrictionAdapt::new(1.0);
        a.since_reversal = 100;
        a.last_reversal_g = 0.0;
        a.reversal(-1.0, 12.0, &[1.0, 0.0, 2e-5, 0.0], &config);
        assert_eq!(a.length, 0);
        // Nor does a half cycle shorter than the mode's (a 40 Hz sine's 12.5 ticks against a
        // 35.7 Hz mode's 14), though its swing is small.
        let mut a = FrictionAdapt::new(1.0);
        a.since_reversal = 12;
        a.last_reversal_g = 8.0;
        a.reversal(-1.0, 12.0, &[1.0, 0.0, 2e-5, 0.0], &config);
        assert_eq!(a.length, 0);
        a.since_reversal = 15;
        a.reversal(1.0, 8.0, &[1.0, 0.0, 2e-5, 0.0], &config);
        assert_eq!(a.length, 14);
    }

    #[test]
    fn the_friction_is_held_in_the_direction_the_reference_last_moved() {
        // A unit plant, no feedback: the drive is the feed-forward, the reference plus the
        // friction terms.
        let cfg = DesignedConfig {
            ki_per_s: 0.0,
            held_friction_g: 0.5,
            ..DesignedConfig::UNIT_PLANT
        };
        let mut t = DesignedController::new(cfg).unwrap();
        let hold = |t: &mut DesignedController, command_g: f32| {
            let mut drive = 0.0;
            for _ in 0..200 {
                drive = t.update(command_g, drive, true).force_g;
            }
            drive
        };
        // Up to 10 g, then down to 5 g: held +0.5 g, then −0.5 g, once the reference rests.
        assert!((hold(&mut t, 10.0) - 10.5).abs() < 1e-3);
        assert!((hold(&mut t, 5.0) - 4.5).abs() < 1e-3);
        // A sine never rests: 5 g at 20 Hz about 10 g gets none of it (the reference's rate
        // passes half of FRICTION_RATE_G_PER_S only near its turns, and briefly).
        let mut plain = DesignedController::new(DesignedConfig {
            held_friction_g: 0.0,
            ..cfg
        })
        .unwrap();
        hold(&mut plain, 5.0);
        let mut worst = 0.0f32;
        for k in 0..1000 {
            let command_g =
                10.0 + 5.0 * crate::trig::sinf(2.0 * core::f32::consts::PI * 0.02 * k as f32);
            let a = t.update(command_g, 0.0, true).force_g;
            let b = plain.update(command_g, 0.0, true).force_g;
            if k > 100 {
                worst = worst.max((a - b).abs());
            }
        }
        assert!(worst < 0.05, "{worst}");
    }

    #[test]
    fn the_friction_turns_through_the_amplifiers_inverse_at_a_reversal_only() {
        // A unit plant with 1 g of friction, no feedback, the same readings: with τ = 2 ms the
        // drive differs from τ = 0 only on the tick the compensation turns through zero, by
        // τ/dt times its change (from +1 g to −1 g: −4 g). A move from rest and a stop get
        // nothing of it: there the motor sticks anyway and the held share carries the friction.
        let cfg = DesignedConfig {
            ki_per_s: 0.0,
            friction_g: 1.0,
            ..DesignedConfig::UNIT_PLANT
        };
        let (mut with, mut without) = (
            DesignedController::new(DesignedConfig {
                amplifier_tau_s: 2e-3,
                ..cfg
            })
            .unwrap(),
            DesignedController::new(cfg).unwrap(),
        );
        // Rest at 10 g, up 500 g/s for 20 ticks, straight down as fast, then rest at 10 g.
        let command = |k: i32| match k {
            ..=100 => 10.0,
            101..=120 => 10.0 + 0.5 * (k - 100) as f32,
            121..=140 => 20.0 - 0.5 * (k - 120) as f32,
            _ => 10.0,
        };
        let mut turns = 0;
        for k in 0..300 {
            let (a, b) = (
                with.update(command(k), 10.0, true).force_g,
                without.update(command(k), 10.0, true).force_g,
            );
            if (a - b).abs() > 1e-4 {
                turns += 1;
                assert!((a - b + 4.0).abs() < 1e-3, "tick {k}: {a} against {b}");
            }
        }
        assert_eq!(turns, 1);
    }

    #[test]
    fn a_rest_unloads_down_a_ramp_then_drives_nothing() {
        // A unit plant on a finger (contact at 0.4 g) whose friction takes 0.8 g: held at 8 g
        // the held share and the integral carry it. Commanded to rest, the reference unloads
        // down the touch-down's ramp reversed, a tick at a time F ← F − (50 g/s + F/0.1 s)·1 ms,
        // that is F = 13·0.99ᵏ − 5 g from 8 g, under a tenth of contact (0.04 g) from tick 95
        // on (by hand); the drive follows it until the reference is there (three poles of
        // 0.8 ms behind) and the last eight readings average under half of contact (the
        // finger unloaded), then is exactly zero (the held share and the integral would push
        // a free probe away from the finger), and the integral keeps what it has. What it
        // learned at 8 g (0.3 g) fades with the ramp: nothing of it is left where the ramp
        // ends (F·0.99 − 0.05 g ≤ 0 from 5 g down; the integral then learns afresh).
        let cfg = DesignedConfig {
            held_friction_g: 0.5,
            contact_g: 0.4,
            ..DesignedConfig::UNIT_PLANT
        };
        let mut t = DesignedController::new(cfg).unwrap();
        let mut drive = 0.0f32;
        for k in 0..5000 {
            // Touched down: the first readings on the finger.
            let sensed = if k < CONTACT_TICKS { 1.0 } else { drive - 0.8 };
            drive = t.update(8.0, sensed.max(0.0), true).force_g;
        }
        assert!(t.landed());
        assert!((drive - 8.8).abs() < 0.01, "{drive}");
        assert!((t.integral_g - 0.3).abs() < 0.01, "{}", t.integral_g);
        let (mut drove, mut kept, mut below_at, mut ramp_end) = (0, None, None, None);
        let mut readings = [drive - 0.8; CONTACT_TICKS];
        for k in 0..200 {
            let above = t.x[0] >= REST_SHARE * 0.4;
            if !above {
                below_at.get_or_insert(k);
            }
            let sensed = (drive + 0.8).max(0.0);
            readings[k % CONTACT_TICKS] = sensed;
            let pressed = readings.iter().sum::<f32>() >= 0.2 * CONTACT_TICKS as f32;
            let ramping = t.ramp_g > 0.0;
            let before = t.integral_g;
            drive = t.update(0.0, sensed, true).force_g;
            if ramping && t.ramp_g == 0.0 {
                // The fade, then this tick's learning (20/s on at most a gram).
                ramp_end.get_or_insert((before, t.integral_g));
            }
            drove += usize::from(above && drive != 0.0);
            if !above && !pressed {
                assert_eq!(drive, 0.0, "tick {k}");
                let learned = *kept.get_or_insert(t.integral_g);
                assert_eq!(t.integral_g, learned, "tick {k}");
            }
        }
        assert!(
            drove > 80 && kept.is_some_and(|i| i != 0.0),
            "{drove} {kept:?}"
        );
        assert!(
            ramp_end.is_some_and(|(before, after)| before.abs() < 0.02 && after.abs() < 0.02),
            "{ramp_end:?}"
        );
        // Behind the ramp by the reference's lag (three 0.8 ms poles) and the ticks' steps.
        assert!(
            below_at.is_some_and(|k| (95..=101).contains(&k)),
            "{below_at:?}"
        );
    }

    #[test]
    fn a_reversal_drops_what_the_integral_carried_against_the_friction() {
        // A unit plant whose friction, 0.8 g of stiction, takes all of it while it holds after
        // moving up: the held share gives 0.5 of it, the integral learns the other 0.3.
        let cfg = DesignedConfig {
            friction_g: 0.8,
            held_friction_g: 0.5,
            ..DesignedConfig::UNIT_PLANT
        };
        let mut t = DesignedController::new(cfg).unwrap();
        let mut drive = 0.0;
        for _ in 0..5000 {
            drive = t.update(10.0, drive - 0.8, true).force_g;
        }
        assert!((t.integral_g - 0.3).abs() < 1e-3, "{}", t.integral_g);
        // Down to 5 g, the friction now the other way: once the reference moves down, the
        // 0.3 g is gone in one tick (the integral alone, 20/s on an error of about a gram,
        // unwinds 0.02 g a tick).
        let mut dropped = None;
        for k in 0..20 {
            let before = t.integral_g;
            drive = t.update(5.0, drive + 0.8, true).force_g;
            if before - t.integral_g > 0.25 {
                dropped = Some(k);
                break;
            }
        }
        assert!(dropped.is_some(), "{}", t.integral_g);
        assert!(t.integral_g.abs() < 0.05, "{}", t.integral_g);
        // Without the held share the integral carried nothing the rule may take: a plant
        // without friction keeps its integral (here a gain error of 2 %) through reversals.
        let mut t = DesignedController::new(DesignedConfig::UNIT_PLANT).unwrap();
        let mut drive = 0.0;
        for _ in 0..5000 {
            drive = t.update(10.0, 0.98 * drive, true).force_g;
        }
        let learned = t.integral_g;
        assert!((learned - 0.2).abs() < 0.01, "{learned}");
        for _ in 0..300 {
            drive = t.update(5.0, 0.98 * drive, true).force_g;
        }
        assert!(t.integral_g > 0.05, "{}", t.integral_g);
    }

    #[test]
    fn a_move_from_rest_drops_what_the_integral_wound_across_the_friction_band() {
        // A unit plant with 1 g of stiction that stood 0.3 g above its drive after moving up to
        // 10 g (a step that stopped past its target, held there by the friction): the
        // integral learned 10 − 0.3 − 10 − 0.5 (held) = −0.8 g, pushing down.
        let cfg = DesignedConfig {
            friction_g: 1.0,
            held_friction_g: 0.5,
            ..DesignedConfig::UNIT_PLANT
        };
        let settled_at = |over_g: f32| {
            let mut t = DesignedController::new(cfg).unwrap();
            let mut drive = 0.0;
            for k in 0..5000 {
                let stuck = if k > 100 { over_g } else { 0.0 };
                drive = t.update(10.0, drive + stuck, true).force_g;
            }
            assert!(
                (t.integral_g + over_g + 0.5).abs() < 1e-3,
                "{}",
                t.integral_g
            );
            (t, drive)
        };
        let settled = || settled_at(0.3);
        // The largest a stuck motor's integral winds: pulled back across the whole band, 1 g
        // over its drive, −1.5 g (the stiction and the held share). A step up slides it
        // against the stiction the compensation now gives whole: all 1.5 g dropped.
        let (mut t, mut drive) = settled_at(1.0);
        let mut jump = 0.0f32;
        for _ in 0..20 {
            let before = t.integral_g;
            drive = t.update(15.0, drive + 1.0, true).force_g;
            jump = jump.max(t.integral_g - before);
        }
        assert!(jump > 1.45, "{jump}");
        // The next step up: the −0.8 g is dropped as the reference leaves rest (the integral
        // alone, 20/s on an error of a gram, would unwind 0.02 g a tick).
        let (mut t, mut drive) = settled();
        let mut dropped = None;
        for k in 0..20 {
            let before = t.integral_g;
            drive = t.update(15.0, drive + 0.3, true).force_g;
            if t.integral_g - before > 0.7 {
                dropped = Some(k);
                break;
            }
        }
        assert!(dropped.is_some(), "{}", t.integral_g);
        // A step down, the integral's direction: the motor slides down against the whole
        // stiction, which the compensation gives, and the −0.8 g (within the band's 1 + 0.5
        // along the move) would push it that much past: dropped too, at once.
        let (mut t, mut drive) = settled();
        let mut dropped = None;
        for k in 0..20 {
            let before = t.integral_g;
            drive = t.update(5.0, drive + 0.3, true).force_g;
            if t.integral_g - before > 0.7 {
                dropped = Some(k);
                break;
            }
        }
        assert!(dropped.is_some(), "{}", t.integral_g);
        // A plant without friction keeps what its integral learned (a gain error of 2 %)
        // through a move from rest either way: no band, nothing to drop.
        let mut t = DesignedController::new(DesignedConfig::UNIT_PLANT).unwrap();
        let mut drive = 0.0;
        for command_g in [10.0, 15.0, 5.0] {
            for _ in 0..5000 {
                let last = t.integral_g;
                drive = t.update(command_g, 0.98 * drive, true).force_g;
                assert!((t.integral_g - last).abs() < 0.05, "{}", t.integral_g);
            }
        }
        // It ends with its 2 % of 5 g.
        assert!((t.integral_g - 0.1).abs() < 0.01, "{}", t.integral_g);
        // A 5 g sine about 10 g at 2 Hz leaves rest once (its start counts) and never rests
        // again: nothing dropped at its turns.
        let (mut t, mut drive) = settled();
        for k in 0..2000 {
            let command_g =
                10.0 + 5.0 * crate::trig::sinf(2.0 * core::f32::consts::PI * 0.002 * k as f32);
            let before = t.integral_g;
            drive = t.update(command_g, drive + 0.3, true).force_g;
            if k > 100 {
                assert!(
                    (t.integral_g - before).abs() < 0.3,
                    "tick {k}: {}",
                    t.integral_g
                );
            }
        }
    }

    #[test]
    fn the_table_round_trips_and_a_damaged_one_is_refused_with_the_reason() {
        let mut cfg = DesignedConfig::UNIT_PLANT;
        cfg.points = 2;
        cfg.schedule[1] = InverseSeries {
            load_g: 50.0,
            c: [1.1, 2e-3, 1e-5, 1e-8],
            feedback: 0.5,
            gauge_s2: 2.2e-6,
        };
        cfg.held_friction_g = 0.3;
        cfg.amplifier_tau_s = 2.2e-3;
        cfg.gauge_g_per_v = 5.8;
        cfg.gauge_max_g = 56.0;
        let bytes = cfg.encode().unwrap();
        assert_eq!(DesignedConfig::decode(&bytes), Ok(cfg));
        // 8 + 4·(21 + 9·7) + 4 bytes.
        assert_eq!(bytes.len(), 348);
        let behind = DesignedConfig {
            amplifier_tau_s: -1e-3,
            ..cfg
        };
        assert_eq!(
            behind.encode(),
            Err(DesignedError::Invalid("amplifier_tau_s"))
        );
        let mut bad = bytes;
        bad[20] ^= 1;
        assert!(matches!(
            DesignedConfig::decode(&bad),
            Err(DesignedError::Checksum { .. })
        ));
        assert_eq!(
            DesignedConfig::decode(&[0xFF; TABLE_BYTES]),
            Err(DesignedError::BadMagic)
        );
        assert_eq!(
            DesignedConfig::decode(&bytes[..100]),
            Err(DesignedError::TooShort {
                bytes: 100,
                needed: TABLE_BYTES
            })
        );
        let mut old = bytes;
        old[4] = 0;
        assert_eq!(
            DesignedConfig::decode(&old),
            Err(DesignedError::UnsupportedVersion { found: 0 })
        );
    }

    #[test]
    fn non_finite_input_gives_the_safe_output() {
        let mut t = DesignedController::new(DesignedConfig::UNIT_PLANT).unwrap();
        let a = t.update(f32::NAN, 0.0, true);
        assert!(a.invalid_input && a.force_g == 0.0);
    }

    #[test]
    fn the_error_passes_the_tables_biquad_and_an_unstable_one_is_refused() {
        // b = (0, 1, 0), a = 0: the error one tick late. With kp 1 and no integral on a unit
        // plant from rest, a step of the command reaches the proportional term a tick after
        // it would unfiltered.
        let mut cfg = DesignedConfig::UNIT_PLANT;
        cfg.kp = 1.0;
        cfg.ki_per_s = 0.0;
        cfg.schedule[0].c = [1e-6, 0.0, 0.0, 0.0];
        let run = |filter: [f32; 5]| {
            let mut c = cfg;
            c.feedback_filter = filter;
            let mut t = DesignedController::new(c).unwrap();
            (0..6)
                .map(|_| t.update(10.0, 0.0, true).force_g)
                .collect::<Vec<f32>>()
        };
        let (plain, late) = (run(FEEDBACK_PASS), run([0.0, 1.0, 0.0, 0.0, 0.0]));
        for k in 0..5 {
            assert!((late[k + 1] - plain[k]).abs() < 1e-4, "{plain:?} {late:?}");
        }
        assert!(late[0].abs() < 1e-4 && plain[0] != 0.0);
        // A pole on or outside the unit circle is refused by name.
        for filter in [
            [1.0, 0.0, 0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0, -2.1, 0.9],
            [f32::NAN; 5],
        ] {
            cfg.feedback_filter = filter;
            assert_eq!(
                DesignedController::new(cfg).err(),
                Some(DesignedError::Invalid("feedback_filter"))
            );
        }
    }
}
