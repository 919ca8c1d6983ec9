//! Sine, cosine and tangent for the arguments the firmware meets (a filter's design frequency,
//! a protocol's phase): reduced by multiples of π/2 in two parts (Cody–Waite: exact for
//! |x| < 2²⁰·π/2), then fdlibm's kernel polynomials on [−π/4, π/4]. libm's own functions carry the
//! Payne–Hanek reduction for any argument (6 KB of flash on the Cortex-M4F, which the board's
//! command channel needed); these agree with them to a unit or two in the last place.
//!
//! ```
//! use tactile_core::trig::{sin_cos, sinf};
//! let (s, c) = sin_cos(1.0);
//! assert!((s - 1f64.sin()).abs() < 1e-15 && (c - 1f64.cos()).abs() < 1e-15);
//! assert_eq!(sinf(0.0), 0.0);
//! ```

/// 2/π.
const INV_PIO2: f64 = core::f64::consts::FRAC_2_PI;
/// The first 33 bits of π/2 (so n·PIO2_1 is exact for n < 2²⁰), and π/2 less them.
const PIO2_1: f64 = 1.570_796_326_734_125_6;
const PIO2_1T: f64 = 6.077_100_506_506_192e-11;

/// sin x and cos x (NaN if x is not finite). Beyond 2²⁰·π/2 the reduction loses what the
/// argument's own rounding already has (about one unit in the last place of x): a phase of
/// hours at tens of hertz, still far finer than a single-precision command.
pub fn sin_cos(x: f64) -> (f64, f64) {
    if !x.is_finite() {
        return (f64::NAN, f64::NAN);
    }
    // The nearest multiple of π/2 (below 2²⁰·π/2, n·PIO2_1 is exact).
    let n = libm::round(x * INV_PIO2);
    let r = (x - n * PIO2_1) - n * PIO2_1T;
    let (s, c) = (kernel_sin(r), kernel_cos(r));
    // NOTE: `as` saturates; past 2⁶³ the quadrant is as meaningless as the argument.
    match (n as i64).rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// tan x, as [`sin_cos`] gives it.
pub fn tan(x: f64) -> f64 {
    let (s, c) = sin_cos(x);
    s / c
}

/// sin x in single precision, through [`sin_cos`] (a protocol's phase).
pub fn sinf(x: f32) -> f32 {
    sin_cos(f64::from(x)).0 as f32
}

/// arctan x in single precision (a plate's load in the contact locator, every frame): the
/// argument folded onto [0, 1] (π/2 − arctan 1/x) and then onto |u| ≤ tan π/12 (π/6 +
/// arctan u), where arctan's series to u¹¹ leaves under 10⁻⁸. Within a few units in the last
/// place of libm's, in a tenth of its flash.
pub fn atanf(x: f32) -> f32 {
    const SQRT_3: f32 = 1.732_050_8;
    const TAN_PI_12: f32 = 0.267_949_2;
    let t = x.abs();
    let (t, inverted) = if t > 1.0 { (1.0 / t, true) } else { (t, false) };
    let (u, offset) = if t > TAN_PI_12 {
        (
            (t * SQRT_3 - 1.0) / (SQRT_3 + t),
            core::f32::consts::FRAC_PI_6,
        )
    } else {
        (t, 0.0)
    };
    let z = u * u;
    let series = u
        * (1.0
            + z * (-1.0 / 3.0
                + z * (1.0 / 5.0 + z * (-1.0 / 7.0 + z * (1.0 / 9.0 - z * (1.0 / 11.0))))));
    let a = offset + series;
    let a = if inverted {
        core::f32::consts::FRAC_PI_2 - a
    } else {
        a
    };
    // NaN stays NaN through the arithmetic; the sign is x's.
    if x < 0.0 {
        -a
    } else {
        a
    }
}

/// √x, correctly rounded as libm's is (so the two agree bit for bit). On the Cortex-M4F the
/// FPU's own instruction: one cycle-cheap `vsqrt` instead of libm's 220 B routine and table.
#[inline]
pub fn sqrtf(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        let root: u32;
        // SAFETY: vsqrt.f32 reads and writes one FPU register (s0, clobbered); the FPU is on in
        // eabihf code. Through a core register: the `sreg` class wants the double-precision FPU.
        unsafe {
            core::arch::asm!(
                "vmov s0, {0}",
                "vsqrt.f32 s0, s0",
                "vmov {0}, s0",
                inout(reg) x.to_bits() => root,
                out("s0") _,
                options(pure, nomem, nostack),
            );
        }
        f32::from_bits(root)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// √x in double precision, correctly rounded as libm's is (so the two agree bit for bit). Only
/// start-up code takes it: on the Cortex-M4F digit by digit, in a fraction of the flash of
/// libm's routine and its 256-byte table.
#[inline]
pub fn sqrt(x: f64) -> f64 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        sqrt_digits(x)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrt(x)
    }
}

/// √x two bits of the significand at a time: 54 bits of the root, the last one rounding (a
/// root's 54th bit is never followed by zeros alone, so there is no tie to break).
#[cfg_attr(not(all(target_arch = "arm", target_abi = "eabihf")), allow(dead_code))]
fn sqrt_digits(x: f64) -> f64 {
    const EXP_MASK: u64 = 0x7ff0_0000_0000_0000;
    let bits = x.to_bits();
    if bits << 1 == 0 || bits == EXP_MASK {
        return x; // ±0, +∞
    }
    if bits > EXP_MASK {
        return f64::NAN; // NaN or negative
    }
    let (mut m, biased) = (bits & ((1 << 52) - 1), (bits >> 52) as i32);
    let mut e = if biased == 0 {
        // Subnormal: its leading bit moved to the implicit bit's place.
        let shift = m.leading_zeros() - 11;
        m <<= shift;
        1 - 1075 - shift as i32
    } else {
        m |= 1 << 52;
        biased - 1075
    };
    // x = m·2^e with e even and m in [2^52, 2^54): the root of m·2^54 is in [2^53, 2^54).
    if e & 1 != 0 {
        m <<= 1;
        e -= 1;
    }
    let (mut pairs, mut rem, mut root) = (m << 10, 0u64, 0u64);
    for _ in 0..54 {
        rem = (rem << 2) | (pairs >> 62);
        pairs <<= 2;
        let trial = (root << 2) | 1;
        root <<= 1;
        if rem >= trial {
            rem -= trial;
            root |= 1;
        }
    }
    // The significand with its implicit bit adds one to the exponent field (and a carry from
    // rounding up to 2^53 one more, as it should).
    let exponent = (e / 2 + 1048) as u64;
    f64::from_bits((exponent << 52) + ((root + 1) >> 1))
}

/// sin r on [−π/4, π/4] (fdlibm's `__kernel_sin`, error under one unit in the last place).
fn kernel_sin(r: f64) -> f64 {
    const S: [f64; 6] = [
        -1.666_666_666_666_663_2e-1,
        8.333_333_333_322_49e-3,
        -1.984_126_982_985_795e-4,
        2.755_731_370_707_006_8e-6,
        -2.505_076_025_340_686_3e-8,
        1.589_690_995_211_55e-10,
    ];
    let z = r * r;
    let v = z * r;
    let p = S[1] + z * (S[2] + z * (S[3] + z * (S[4] + z * S[5])));
    r + v * (S[0] + z * p)
}

/// cos r on [−π/4, π/4] (fdlibm's `__kernel_cos`).
fn kernel_cos(r: f64) -> f64 {
    const C: [f64; 6] = [
        4.166_666_666_666_66e-2,
        -1.388_888_888_887_411e-3,
        2.480_158_728_947_673e-5,
        -2.755_731_435_139_066_3e-7,
        2.087_572_321_298_175e-9,
        -1.135_964_755_778_819_5e-11,
    ];
    let z = r * r;
    let w = z * z;
    let p = z * (C[0] + z * (C[1] + z * C[2])) + w * w * (C[3] + z * (C[4] + z * C[5]));
    let hz = 0.5 * z;
    let one_less = 1.0 - hz;
    one_less + (((1.0 - one_less) - hz) + z * p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::FRAC_PI_2;

    /// Against the host's libm over many periods and at the quadrant boundaries: within
    /// two units in the last place of the larger of the value and 1e-16 (near a zero the
    /// reduction's absolute error shows).
    #[test]
    fn agrees_with_libm_over_many_periods() {
        let mut worst: f64 = 0.0;
        for i in -200_000..200_000 {
            let x = i as f64 * 0.012_345_678_9 + 1e-3;
            let (s, c) = sin_cos(x);
            let (es, ec) = (x.sin(), x.cos());
            let tol = |e: f64| 2.0 * f64::EPSILON * e.abs().max(0.5) + 1e-16 * x.abs().max(1.0);
            assert!((s - es).abs() <= tol(es), "sin {x}: {s} {es}");
            assert!((c - ec).abs() <= tol(ec), "cos {x}: {c} {ec}");
            worst = worst.max((s - es).abs());
        }
        assert!(worst > 0.0);
        for k in -8..=8 {
            let x = k as f64 * FRAC_PI_2;
            let (s, c) = sin_cos(x);
            assert!(
                (s - x.sin()).abs() < 1e-15 && (c - x.cos()).abs() < 1e-15,
                "{k}"
            );
        }
        assert!((tan(0.7) - 0.7f64.tan()).abs() < 1e-15);
        assert_eq!(sinf(1.5), 1.5f32.sin());
        assert!(sin_cos(f64::NAN).0.is_nan() && sin_cos(f64::INFINITY).1.is_nan());
        // An hour at 50 Hz: what the argument's rounding allows.
        let x = 2.0 * core::f64::consts::PI * 50.0 * 3600.0 + 0.3;
        assert!((sin_cos(x).0 - x.sin()).abs() < 1e-9);
    }

    /// Digit by digit against libm, bit for bit: random bit patterns over every exponent,
    /// subnormals, perfect squares and their neighbours, and the special values.
    #[test]
    fn sqrt_digits_is_libms_bit_for_bit() {
        let same = |x: f64| {
            let (a, b) = (sqrt_digits(x), libm::sqrt(x));
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "{x:e}: {a:e} {b:e}"
            );
        };
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..2_000_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            same(f64::from_bits(state >> 1));
            same(f64::from_bits(state >> 12)); // subnormal
        }
        for k in 1..100_000u64 {
            let sq = (k * k) as f64;
            for x in [
                sq,
                f64::from_bits(sq.to_bits() - 1),
                f64::from_bits(sq.to_bits() + 1),
            ] {
                same(x);
                same(x * 1e-300);
            }
        }
        for x in [
            0.0,
            -0.0,
            1.0,
            2.0,
            f64::MAX,
            f64::MIN_POSITIVE,
            5e-324,
            f64::INFINITY,
        ] {
            same(x);
        }
        assert_eq!(sqrt_digits(-0.0).to_bits(), (-0.0f64).to_bits());
        for x in [-1.0, -5e-324, f64::NEG_INFINITY, f64::NAN] {
            assert!(sqrt_digits(x).is_nan());
        }
    }

    /// Against the host's arctan over the whole line: within 4·10⁻⁷ of the value (a few
    /// units in the last place), exact at 0, ±π/2 at ±∞, NaN kept.
    #[test]
    fn atanf_agrees_with_the_hosts() {
        for i in -100_000..100_000 {
            let x = (i as f32 * 1e-4).powi(3) * 50.0;
            let (a, e) = (atanf(x), f64::from(x).atan());
            assert!(
                (f64::from(a) - e).abs() <= 4e-7 * e.abs().max(1e-30),
                "{x}: {a} {e}"
            );
        }
        assert_eq!(atanf(0.0), 0.0);
        assert_eq!(atanf(f32::INFINITY), core::f32::consts::FRAC_PI_2);
        assert_eq!(atanf(f32::NEG_INFINITY), -core::f32::consts::FRAC_PI_2);
        assert!(atanf(f32::NAN).is_nan());
    }
}
