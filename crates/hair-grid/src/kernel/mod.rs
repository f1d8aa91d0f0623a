//! The instruction-set kernels of the pair search and of the rebuild's covers, one module per
//! instruction set behind one interface ([`Isa`]), chosen by [`GridConfig::kernel`]
//! ([`Kernel`]).
//!
//! Every kernel gives the same cells and the same pairs in the same order: the wide ones run the
//! scalar expressions lane for lane (Rust never fuses or reorders floating-point operations,
//! whatever the instruction set), and tests check each kernel against the others. Only the time
//! differs, so benchmark figures name the kernel they ran (`docs/perf/grid.md`).
//!
//! - [`baseline`]: SSE2 box tests on x86-64 (part of every x86-64 processor), plain Rust
//!   elsewhere; the exact test in plain Rust, eight lanes.
//! - `avx2`: a cell in blocks of sixteen sections, eight boxes per compare; the exact test eight
//!   lanes per instruction; eight covers at once in two halves of four `f64` lanes.
//! - `avx512`: sixteen boxes per compare with the neighbour and owner tests lane-wise and one
//!   compress per block; the exact test sixteen lanes; eight covers at once.
//!
//! The wide kernels are reached only through a token ([`avx2::Avx2`], [`avx512::Avx512`]) that
//! exists only once the processor has been found to have the instructions, so that their
//! `#[target_feature]` functions are called only where they can run.
//!
//! [`GridConfig::kernel`]: crate::GridConfig::kernel

use std::ops::Range;

use crate::grid::Covers8;
#[cfg(target_arch = "x86_64")]
use crate::pairs::{Block16, PBox};
use crate::pairs::{CellEntries, CellWork, Line, PairChunk, Report};
use crate::{Grid, GridError, Real, Section};

pub(crate) mod baseline;

/// The exact test's arithmetic on lanes of a vector type `$v`: from the transposed cores `$p`
/// and `$q` (eight registers each: `a`, `b`, radius, scale), the LSS-LSS distances and the
/// rounding bands, as `(d, band)`. Written once for the AVX2 and AVX-512 kernels, which then
/// run the same operations in the same order (hair-ssv's segment-segment kernel, lane-wise).
/// `$gt` compares into a lane mask, and `$select(mask, no, yes)` takes `yes` where it is set.
#[cfg(target_arch = "x86_64")]
macro_rules! lss_lanes {
    ($p:expr, $q:expr, $v:ty, $add:expr, $sub:expr, $mul:expr, $div:expr, $min:expr,
     $max:expr, $sqrt:expr, $splat:expr, $gt:expr, $select:expr) => {{
        let (p, q) = ($p, $q);
        let (add, sub, mul, div) = ($add, $sub, $mul, $div);
        let zero = $splat(0.0);
        let one = $splat(1.0);
        // `x.clamp(0.0, 1.0)` for any `x` but NaN's payload: `max(0, x)` keeps `x` when it is
        // NaN or -0.0 (the second operand wins ties and NaN), as `clamp` does.
        let clamp01 = |x: $v| $min(one, $max(zero, x));
        let dot =
            |a: [$v; 3], b: [$v; 3]| add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]));
        let cross = |a: [$v; 3], b: [$v; 3]| {
            [
                sub(mul(a[1], b[2]), mul(a[2], b[1])),
                sub(mul(a[2], b[0]), mul(a[0], b[2])),
                sub(mul(a[0], b[1]), mul(a[1], b[0])),
            ]
        };
        let u = [0, 1, 2].map(|k| sub(p[3 + k], p[k]));
        let v = [0, 1, 2].map(|k| sub(q[3 + k], q[k]));
        let r = [sub(p[0], q[0]), sub(p[1], q[1]), sub(p[2], q[2])];
        let a = dot(u, u);
        let e = dot(v, v);
        let b = dot(u, v);
        let c = dot(u, r);
        let f = dot(v, r);
        let denom = sub(mul(a, e), mul(b, b));
        let classic = div(sub(mul(b, f), mul(c, e)), denom);
        let n = cross(u, v);
        let m = cross(v, r);
        let nn = dot(n, n);
        let crossed = div(dot(n, m), nn);
        let s0 = $select($gt(nn, zero), zero, crossed);
        let s0 = $select($gt(denom, mul(mul($splat(0.0625), a), e)), s0, classic);
        let s0 = clamp01(s0);
        let inv_e = $select($gt(e, zero), zero, div(one, e));
        let inv_a = $select($gt(a, zero), zero, div(one, a));
        let t = clamp01(mul(add(mul(b, s0), f), inv_e));
        let s = clamp01(mul(sub(mul(b, t), c), inv_a));
        let w = [0, 1, 2].map(|k| sub(add(r[k], mul(u[k], s)), mul(v[k], t)));
        let d = sub($sqrt(dot(w, w)), add(p[6], q[6]));
        // `p.max(q)` for the scales, which are never NaN (at least 1).
        (d, mul($splat(1e-5), $max(p[7], q[7])))
    }};
}

/// `short_line`'s arithmetic on lanes, for the sections whose cover lies within 2 x 2 x 2 cells:
/// from the ends in cells `$va`, `$vb` and the radius `$radius` (`f64` lanes), the lanes that are
/// such a cover (bits, from `$ok`, the lanes that are an LSS), the cell ranges' low and high
/// corners (`i64` lanes) and the masks of `cover::small_mask`, as `(ok, cl, ch, mask)`.
/// Written once for the AVX-512 and AVX2 kernels, which then run the same operations in the same
/// order. `$cmp::<P>(a, b)` compares into a lane mask, `$and` joins two, `$bits` turns one into
/// bits, `$blend(m, no, yes)` takes `yes` where it is set, `$floor` is `floor_small` as an integer
/// and a float, `$narrow` the bits of the integer lanes of at most 2, `$single` the mask of those
/// of 1, and `$set(mask, m, bit)` sets `bit` in the integer lanes where `m` is set. Every case of
/// the scalar small mask is computed and then selected: which one applies is as likely one way
/// as the other, and in the scalar loop their branches mispredict.
#[cfg(target_arch = "x86_64")]
macro_rules! small_cover_lanes {
    ($va:expr, $vb:expr, $radius:expr, $ok:expr, $inv:expr, $grow:expr, $v:ty,
     add: $add:expr, sub: $sub:expr, mul: $mul:expr, div: $div:expr, min: $min:expr,
     max: $max:expr, abs: $abs:expr, splat: $splat:expr, cmp: $cmp:ident, and: $and:expr,
     bits: $bits:expr, blend: $blend:expr, floor: $floor:expr, int_sub: $isub:expr,
     int_one: $ione:expr, int_add: $iadd:expr, narrow: $narrow:expr, single: $single:expr,
     int_zero: $izero:expr, set: $set:expr) => {{
        let (va, vb, radius): ([$v; 3], [$v; 3], $v) = ($va, $vb, $radius);
        let (add, sub, mul, min, max, blend, and) = ($add, $sub, $mul, $min, $max, $blend, $and);
        let (zero, one): ($v, $v) = ($splat(0.0), $splat(1.0));
        let inv_v = $splat($inv);
        let r = add(
            mul(add(radius, $splat($grow)), inv_v),
            $splat($crate::grid::EPS_CELLS),
        );
        let half = $splat($crate::cell_key::LATTICE_HALF as f64);
        // Not negative (NaN fails too, through `r` below).
        let mut ok: u32 = $ok & $bits($cmp::<_CMP_GE_OQ>(radius, zero));
        let mut cl = [$izero; 3];
        let mut ch = [$izero; 3];
        let mut axes = [[zero; 4]; 3];
        for k in 0..3 {
            let (a, b) = (va[k], vb[k]);
            // `if a < b { (a, b) } else { (b, a) }`.
            let (mn, mx) = (min(a, b), max(b, a));
            let (lo, hi) = (sub(mn, r), add(mx, r));
            ok &= $bits(and(
                $cmp::<_CMP_GE_OQ>(lo, sub(zero, half)),
                $cmp::<_CMP_LT_OQ>(hi, half),
            ));
            let (lo_i, lo_f) = $floor(lo);
            let (hi_i, _) = $floor(hi);
            cl[k] = lo_i;
            ch[k] = hi_i;
            let n = $iadd($isub(hi_i, lo_i), $ione);
            // At most two cells along every axis.
            ok &= $narrow(n);
            let single = $single(n);
            // `cover::small_mask`'s bounds of the axis, every case.
            let d = sub(b, a);
            let inv_d = $div(one, d);
            let base = sub(lo_f, a);
            let up = mul(add(add(base, one), r), inv_d);
            let down = mul(sub(add(base, one), r), inv_d);
            let rising = $cmp::<_CMP_GT_OQ>(d, zero);
            let sloped = [
                blend(rising, max(up, zero), zero),
                blend(rising, one, min(up, one)),
                blend(rising, zero, max(down, zero)),
                blend(rising, min(down, one), one),
            ];
            let upper = |f: $v| {
                let inside = and(
                    $cmp::<_CMP_GE_OQ>(a, sub(f, r)),
                    $cmp::<_CMP_LE_OQ>(a, add(add(f, one), r)),
                );
                blend(inside, $splat(-1.0), one)
            };
            let flat = [zero, upper(lo_f), zero, upper(add(lo_f, one))];
            let slanted = $cmp::<_CMP_GT_OQ>($abs(d), $splat($crate::cover::TINY));
            let one_cell = [zero, one, $splat(2.0), $splat(-1.0)];
            axes[k] = std::array::from_fn(|j| {
                let along = blend(slanted, flat[j], sloped[j]);
                blend(single, along, one_cell[j])
            });
        }
        let [x, y, z] = axes;
        let mut mask = $izero;
        for i in 0..2 {
            for j in 0..2 {
                let y0 = max(y[2 * j], x[2 * i]);
                let y1 = min(y[2 * j + 1], x[2 * i + 1]);
                for k in 0..2 {
                    let keep = $cmp::<_CMP_LE_OQ>(max(z[2 * k], y0), min(z[2 * k + 1], y1));
                    mask = $set(mask, keep, 1i64 << (4 * i + 2 * j + k));
                }
            }
        }
        (ok, cl, ch, mask)
    }};
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;

/// Which instruction set the grid's pair search and cover computation use
/// ([`GridConfig::kernel`](crate::GridConfig::kernel)).
///
/// Every kernel gives the same cells and the same pairs in the same order; only the time
/// differs. [`Kernel::Auto`], the default, runs the widest one the processor has.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Kernel {
    /// The widest kernel this processor runs ([`Kernel::widest_available`]).
    #[default]
    Auto,
    /// SSE2 box tests on x86-64 (every x86-64 processor has them), plain Rust elsewhere.
    Baseline,
    /// AVX2 rows, exact test and covers (x86-64).
    Avx2,
    /// AVX-512F rows, exact test and covers (x86-64 with AVX-512F, AVX2, POPCNT and BMI1).
    Avx512,
}

impl Kernel {
    /// The kernel of a name: `"auto"`, `"avx512"`, `"avx2"` or `"baseline"` (as
    /// [`Kernel::name`] gives them; exact, lower case).
    ///
    /// # Errors
    /// [`GridError::UnknownKernel`] for any other name.
    pub fn from_name(name: &str) -> Result<Self, GridError> {
        match name {
            "auto" => Ok(Kernel::Auto),
            "avx512" => Ok(Kernel::Avx512),
            "avx2" => Ok(Kernel::Avx2),
            "baseline" => Ok(Kernel::Baseline),
            _ => Err(GridError::UnknownKernel {
                name: name.to_owned(),
            }),
        }
    }

    /// The kernel's name: `"auto"`, `"avx512"`, `"avx2"` or `"baseline"`.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Auto => "auto",
            Kernel::Baseline => "baseline",
            Kernel::Avx2 => "avx2",
            Kernel::Avx512 => "avx512",
        }
    }

    /// The widest kernel this processor runs (never [`Kernel::Auto`]; the processor is asked
    /// once by the standard library, then the answer is cached).
    pub fn widest_available() -> Self {
        Selected::widest().kernel()
    }

    /// Whether this processor runs the kernel ([`Kernel::Auto`] and [`Kernel::Baseline`]
    /// always).
    pub fn is_available(self) -> bool {
        Selected::exactly(self).is_some()
    }
}

impl std::fmt::Display for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Kernel {
    type Err = GridError;

    /// [`Kernel::from_name`].
    fn from_str(name: &str) -> Result<Self, GridError> {
        Self::from_name(name)
    }
}

/// The kernel a grid runs, resolved against this processor: a token for each wide kernel,
/// which exists only once its instructions were found.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Selected {
    Baseline(baseline::Baseline),
    #[cfg(target_arch = "x86_64")]
    Avx2(avx2::Avx2),
    #[cfg(target_arch = "x86_64")]
    Avx512(avx512::Avx512),
}

impl Selected {
    /// The widest kernel this processor runs.
    pub(crate) fn widest() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(k) = avx512::Avx512::detect() {
                return Selected::Avx512(k);
            }
            if let Some(k) = avx2::Avx2::detect() {
                return Selected::Avx2(k);
            }
        }
        Selected::Baseline(baseline::Baseline)
    }

    /// `kernel` on this processor, `None` when it lacks the instructions ([`Kernel::Auto`]: the
    /// widest it has).
    pub(crate) fn exactly(kernel: Kernel) -> Option<Self> {
        match kernel {
            Kernel::Auto => Some(Self::widest()),
            Kernel::Baseline => Some(Selected::Baseline(baseline::Baseline)),
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2 => avx2::Avx2::detect().map(Selected::Avx2),
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512 => avx512::Avx512::detect().map(Selected::Avx512),
            #[cfg(not(target_arch = "x86_64"))]
            Kernel::Avx2 | Kernel::Avx512 => None,
        }
    }

    /// `kernel`, or the widest narrower one this processor runs when it lacks it.
    pub(crate) fn at_most(kernel: Kernel) -> Self {
        match kernel {
            Kernel::Avx512 => Self::exactly(Kernel::Avx512).unwrap_or(Self::at_most(Kernel::Avx2)),
            Kernel::Avx2 => {
                Self::exactly(Kernel::Avx2).unwrap_or(Selected::Baseline(baseline::Baseline))
            }
            Kernel::Auto | Kernel::Baseline => Self::exactly(kernel).unwrap_or(Self::widest()),
        }
    }

    /// `kernel` on this processor.
    ///
    /// # Errors
    /// [`GridError::KernelUnavailable`] when the processor lacks its instructions.
    pub(crate) fn try_new(kernel: Kernel) -> Result<Self, GridError> {
        Self::exactly(kernel).ok_or(GridError::KernelUnavailable {
            kernel: kernel.name(),
            widest: Self::widest().kernel().name(),
        })
    }

    /// The kernel this is.
    pub(crate) fn kernel(self) -> Kernel {
        match self {
            Selected::Baseline(_) => Kernel::Baseline,
            #[cfg(target_arch = "x86_64")]
            Selected::Avx2(_) => Kernel::Avx2,
            #[cfg(target_arch = "x86_64")]
            Selected::Avx512(_) => Kernel::Avx512,
        }
    }

    /// One task of the pair search ([`Isa::task`]) with this kernel.
    pub(crate) fn task(
        self,
        grid: &Grid,
        cells: Range<usize>,
        chunk: &mut PairChunk,
        report: Report,
    ) {
        match self {
            Selected::Baseline(k) => k.task(grid, cells, chunk, report),
            #[cfg(target_arch = "x86_64")]
            Selected::Avx2(k) => k.task(grid, cells, chunk, report),
            #[cfg(target_arch = "x86_64")]
            Selected::Avx512(k) => k.task(grid, cells, chunk, report),
        }
    }

    /// [`Isa::small_covers`] with this kernel.
    #[inline(always)]
    pub(crate) fn small_covers(self, secs: &[Section], inv: f64, grow: f64, out: &mut Covers8) {
        match self {
            Selected::Baseline(k) => k.small_covers(secs, inv, grow, out),
            #[cfg(target_arch = "x86_64")]
            Selected::Avx2(k) => k.small_covers(secs, inv, grow, out),
            #[cfg(target_arch = "x86_64")]
            Selected::Avx512(k) => k.small_covers(secs, inv, grow, out),
        }
    }
}

/// What the pair search and the rebuild ask of an instruction set. Each implementation is a
/// token that exists only on a processor with its instructions, so that these safe methods may
/// call its `#[target_feature]` functions.
pub(crate) trait Isa: Copy + Send + Sync {
    /// Candidates per call of [`Isa::exact`]: eight or sixteen.
    const EXACT_LANES: usize;

    /// One task of the pair search ([`Grid::task`]: the pairs first reported by `cells`), compiled
    /// for this instruction set, so that the generic search code inlined into it uses its
    /// instructions too.
    fn task(self, grid: &Grid, cells: Range<usize>, chunk: &mut PairChunk, report: Report);

    /// The candidates first reported by one cell, into `work.cand` (flushed through
    /// [`Grid::finish`] as it fills).
    fn cell(self, grid: &Grid, cell: &CellEntries, work: &mut CellWork, report: Report);

    /// The exact test on the first [`Isa::EXACT_LANES`] candidates of `block` (internal
    /// indices): `(sure, open)` lane masks, the distance surely within `margin`, or within a
    /// rounding band of it (or NaN: not two LSS) so that the scalar test must decide.
    fn exact(self, lines: &[Line], block: &[[u32; 2]], margin: Real) -> (u32, u32);

    /// The short covers of up to eight sections at once whose cover lies within 2 x 2 x 2
    /// cells, as `short_line` gives them; `None` for every other section (the scalar path
    /// covers or rejects it). A kernel without lanes for it leaves `out` as it is.
    fn small_covers(self, secs: &[Section], inv: f64, grow: f64, out: &mut Covers8);
}

/// The rows of a cell laid out in blocks of sixteen sections (`Grid::cell_pairs_blocks`): the
/// AVX2 and AVX-512 kernels.
#[cfg(target_arch = "x86_64")]
pub(crate) trait BlockRows: Isa {
    /// Fills `blocks` with the sections `ents` (internal indices) of a cell and their
    /// earlier-cell bit sets, sixteen per block, the lanes past the last section with NaN boxes
    /// (which fail every comparison); returns the union of the bit sets.
    fn gather(self, boxes: &[PBox], ents: &[u32], earlier: &[u64], blocks: &mut [Block16]) -> u64;

    /// Row `a` of a cell of `m` sections in blocks: the pairs of section `a` with the later
    /// sections that this cell reports, written to the start of `row` (room for one per later
    /// section, and sixteen more), and their count. `special`: the cell holds bit sets with
    /// `OUTSIDE` or `UNKNOWN`; `unknown`: with `UNKNOWN`. `None` when a pair's owner is one
    /// the bit sets cannot tell, for `Grid::row_blocks` to do the row again with the key lists.
    #[expect(
        clippy::too_many_arguments,
        reason = "one row's inputs, kept in registers"
    )]
    fn row(
        self,
        blocks: &[Block16],
        m: usize,
        a: usize,
        skip: u32,
        special: bool,
        unknown: bool,
        row: &mut [[u32; 2]],
    ) -> Option<usize>;
}

/// The sections' ends and radii by lane into `f` (`[a.x, a.y, a.z, b.x, b.y, b.z, radius]`, each
/// eight lanes, zeros to begin with); returns the lanes that are an LSS as bits. A lane that is
/// not keeps zeros, and the lane kernels drop it.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn lines8(secs: &[Section], f: &mut [[f32; 8]; 7]) -> u32 {
    let mut line = 0u32;
    for (l, s) in secs.iter().take(8).enumerate() {
        if let crate::Ssv::Line(ln) = &s.shape {
            for k in 0..3 {
                f[k][l] = ln.a[k];
                f[3 + k][l] = ln.b[k];
            }
            f[6][l] = ln.radius;
            line |= 1 << l;
        }
    }
    line
}

/// The covers of the lanes set in `ok` from their corners and masks (lanes `first..`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn covers_out<const N: usize>(
    out: &mut Covers8,
    first: usize,
    len: usize,
    ok: u32,
    (cl, ch, mask): (&[[i64; N]; 3], &[[i64; N]; 3], &[i64; N]),
) {
    for l in 0..N {
        let o = first + l;
        if o < len && ok & (1 << l) != 0 {
            out[o] = Some((
                [cl[0][l], cl[1][l], cl[2][l]],
                [ch[0][l], ch[1][l], ch[2][l]],
                crate::grid::SMALL | mask[l] as u64,
            ));
        }
    }
}

/// `floor_small`'s constant: `1.5 * 2^52`, whose sum with a small value rounds it to an integer
/// held in the low bits.
#[cfg(target_arch = "x86_64")]
const MAGIC: f64 = 6_755_399_441_055_744.0;

/// A seeded generator for the kernel tests.
#[cfg(test)]
pub(crate) fn lcg(z: &mut u64) -> f32 {
    *z = z
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*z >> 40) as f32 / (1u64 << 24) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pairs::LANES;
    use crate::{Point, Ssv};
    use hair_ssv::Lss;

    #[test]
    fn kernels_are_named_and_parsed_back() {
        for k in [Kernel::Auto, Kernel::Baseline, Kernel::Avx2, Kernel::Avx512] {
            assert_eq!(Kernel::from_name(k.name()), Ok(k));
            assert_eq!(k.to_string().parse::<Kernel>(), Ok(k));
        }
        assert_eq!(
            Kernel::from_name("avx1024"),
            Err(GridError::UnknownKernel {
                name: "avx1024".into()
            })
        );
        assert!(Kernel::from_name("AVX2").is_err());
        assert_eq!(Kernel::default(), Kernel::Auto);
    }

    #[test]
    fn auto_is_the_widest_kernel_and_a_missing_one_is_refused_or_narrowed() {
        let widest = Kernel::widest_available();
        assert_ne!(widest, Kernel::Auto);
        assert!(Kernel::Baseline.is_available() && Kernel::Auto.is_available());
        assert_eq!(Selected::at_most(Kernel::Auto).kernel(), widest);
        for k in [Kernel::Baseline, Kernel::Avx2, Kernel::Avx512] {
            match Selected::try_new(k) {
                Ok(s) => {
                    assert!(k.is_available());
                    assert_eq!(s.kernel(), k);
                    assert_eq!(Selected::at_most(k).kernel(), k);
                }
                Err(e) => {
                    assert!(!k.is_available());
                    assert_eq!(
                        e,
                        GridError::KernelUnavailable {
                            kernel: k.name(),
                            widest: widest.name()
                        }
                    );
                    // Narrowed: never wider than asked.
                    let narrowed = Selected::at_most(k).kernel();
                    assert!(
                        narrowed == Kernel::Baseline || narrowed == Kernel::Avx2,
                        "{narrowed}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_lane_kernels_decide_as_the_scalar_distance() {
        let mut z = 9u64;
        // Segments on a coarse lattice (parallel, touching, crossing and zero-length ones come
        // up often), some with a NaN radius (not an LSS: always undecided).
        let line = |z: &mut u64| -> Line {
            let at = |z: &mut u64| (lcg(z) * 8.0).floor() * 0.25;
            let a = [at(z), at(z), at(z)];
            let u = if lcg(z) < 0.1 {
                [0.0; 3]
            } else {
                [at(z) - 1.0, at(z) - 1.0, at(z) - 1.0]
            };
            let radius = if lcg(z) < 0.05 {
                f32::NAN
            } else {
                lcg(z) * 0.5
            };
            let b = [0, 1, 2].map(|k| a[k] + u[k]);
            let scale = a.iter().chain(&b).map(|c| c.abs()).fold(1.0f32, f32::max);
            [a[0], a[1], a[2], b[0], b[1], b[2], radius, scale]
        };
        let lines: Vec<Line> = (0..64).map(|_| line(&mut z)).collect();
        let scalar = |l: &Line, m: &Line| {
            let shape = |l: &Line| {
                Ssv::Line(Lss::new(
                    Point::new(l[0], l[1], l[2]),
                    Point::new(l[3], l[4], l[5]),
                    l[6],
                ))
            };
            shape(l).distance(&shape(m))
        };
        let mut decided = 0;
        let mut previous = vec![[0u32, 1u32]; LANES];
        let mut wide16 = 0;
        for _ in 0..500 {
            let block: Vec<[u32; 2]> = (0..LANES)
                .map(|_| [(lcg(&mut z) * 64.0) as u32, (lcg(&mut z) * 64.0) as u32])
                .collect();
            let margin = if lcg(&mut z) < 0.5 { 0.0 } else { 0.1 };
            let (sure, open) = baseline::lanes_decide(&lines, &block, margin);
            for (l, &[a, b]) in block.iter().enumerate() {
                let (la, lb) = (&lines[a as usize], &lines[b as usize]);
                if open >> l & 1 == 0 {
                    decided += 1;
                    let within = scalar(la, lb) <= margin;
                    assert_eq!(sure >> l & 1 != 0, within, "{la:?} {lb:?}");
                } else {
                    assert_eq!(sure >> l & 1, 0);
                }
            }
            #[cfg(target_arch = "x86_64")]
            if let Some(k) = avx2::Avx2::detect() {
                assert_eq!(k.exact(&lines, &block, margin), (sure, open));
            }
            // Sixteen lanes: this block, then the previous one.
            #[cfg(target_arch = "x86_64")]
            if let Some(k) = avx512::Avx512::detect() {
                let pair: Vec<[u32; 2]> = block.iter().chain(&previous).copied().collect();
                let wide = k.exact(&lines, &pair, margin);
                let (sure_p, open_p) = baseline::lanes_decide(&lines, &previous, margin);
                assert_eq!(wide, (sure | sure_p << 8, open | open_p << 8));
                wide16 += 1;
            }
            previous = block;
        }
        if Kernel::Avx512.is_available() {
            assert_eq!(wide16, 500);
        }
        assert!(decided > 3000, "{decided}");
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn eight_short_covers_at_once_are_the_scalar_ones() {
        let (avx512, Some(avx2)) = (avx512::Avx512::detect(), avx2::Avx2::detect()) else {
            eprintln!("no AVX2 on this processor: the AVX2 and AVX-512 covers are not tested");
            return;
        };
        if avx512.is_none() {
            eprintln!("no AVX-512F on this processor: the AVX-512 covers are not tested");
        }
        // Seeded segments of about one cell and of a few, with the cases of `small_mask`: along
        // a lattice axis, nearly so, ends on cell faces, single points, and bad shapes.
        let mut z = 5u64;
        let mut unit = || {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (z >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut wide, mut small) = (0, 0);
        for n in 0..4_000 {
            let (inv, grow) = (1.0 + f64::from(unit()), f64::from(unit()) * 0.01);
            let secs: Vec<Section> = (0..8)
                .map(|k| {
                    let case = (n * 8 + k) % 11;
                    let mut a =
                        Point::new(unit() * 8.0 - 4.0, unit() * 8.0 - 4.0, unit() * 8.0 - 4.0);
                    if case == 1 {
                        a = a.map(|c| c.round());
                    }
                    let span = if case == 2 { 3.0 } else { 1.2 };
                    let mut b =
                        a + crate::Vector::new(unit() - 0.5, unit() - 0.5, unit() - 0.5) * span;
                    match case {
                        3 => b[k % 3] = a[k % 3],
                        4 => b[k % 3] = a[k % 3] + 1e-9,
                        5 => b = a,
                        _ => {}
                    }
                    let radius = match case {
                        6 => -0.1,
                        7 => f32::NAN,
                        8 => 0.0,
                        _ => unit() * 0.2,
                    };
                    if case == 9 {
                        b.x = f32::INFINITY;
                    }
                    let shape = if case == 10 {
                        Ssv::Point(hair_ssv::Pss::new(a, radius.abs()))
                    } else {
                        Ssv::Line(Lss::new(a, b, radius))
                    };
                    Section {
                        skeleton: 0,
                        segment: k as u32,
                        shape,
                    }
                })
                .collect();
            let mut group = [None; 8];
            avx2.small_covers(&secs, inv, grow, &mut group);
            if let Some(avx512) = avx512 {
                // Whatever `out` held before is replaced.
                let mut group512 = [Some(([0; 3], [0; 3], 0)); 8];
                avx512.small_covers(&secs, inv, grow, &mut group512);
                assert_eq!(group512, group);
            }
            // Fewer than eight sections: the lanes past them are emptied.
            let mut five = [Some(([0; 3], [0; 3], 0)); 8];
            avx2.small_covers(&secs[..5], inv, grow, &mut five);
            assert_eq!(five[..5], group[..5]);
            assert_eq!(five[5..], [None; 3]);
            for (s, got) in secs.iter().zip(group) {
                let scalar = match &s.shape {
                    Ssv::Line(l) => crate::grid::short_line(l, inv, grow),
                    _ => None,
                };
                // Every cover of at most 2 x 2 x 2 cells comes out, exactly as the scalar one.
                match scalar {
                    Some((_, _, mask)) if mask & crate::grid::SMALL != 0 => {
                        assert_eq!(got, scalar, "{s:?}");
                        small += 1;
                    }
                    _ => assert_eq!(got, None, "{s:?}"),
                }
                wide += usize::from(got.is_some());
            }
        }
        assert!(wide > 10_000 && small == wide, "{wide} {small}");
    }
}
