//! Procedural surface texture: hashed value noise at a few scales, in surface coordinates
//! (metres), so both cameras see the same pattern on the same patch of world.
//!
//! Octaves finer than the pixel footprint fade to their mean instead of aliasing into noise
//! that differs between the left and right views (a crude level of detail, enough for block
//! matching at every range).

/// Cell sizes of the octaves, finest first (m).
const CELLS_M: [f32; 4] = [0.04, 0.15, 0.6, 2.5];
/// Weight of each octave in the sum; they add up to 1.
const WEIGHTS: [f32; 4] = [0.35, 0.3, 0.2, 0.15];
/// An octave is at full strength with at least this many pixels per cell, and gone at half.
const FULL_STRENGTH_PX_PER_CELL: f32 = 3.0;

/// The noise's mean, which an octave finer than the pixel footprint shows instead.
const MEAN: f32 = 0.5;

/// Seeded value noise.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Texture {
    seed: u32,
    /// Per octave, the bits of the largest footprint (m) at which it shows: it shows at a
    /// footprint exactly when the footprint's bits are no greater (NaN and negative footprints,
    /// whose bits are greater than every positive one's, show none), a test without division.
    shows_up_to_bits: [u32; 4],
}

impl Texture {
    pub(crate) fn new(seed: u64) -> Texture {
        Texture {
            seed: (seed ^ (seed >> 32)) as u32,
            shows_up_to_bits: CELLS_M.map(largest_showing_footprint_bits),
        }
    }

    /// Brightness of surface `material` at surface coordinates `(u, v)` (m), in [0, 1] with
    /// mean 0.5, seen with a pixel footprint of `footprint_m` metres: one texel at a time, as
    /// the reference renderer samples.
    #[cfg(any(test, feature = "render-reference"))]
    pub(crate) fn sample(&self, material: u32, u: f32, v: f32, footprint_m: f32) -> f32 {
        let mut value = 0.0;
        for (octave, (&cell, &weight)) in CELLS_M.iter().zip(&WEIGHTS).enumerate() {
            let strength = octave_strength(cell, footprint_m);
            let noise = if strength > 0.0 {
                self.value_noise(material.wrapping_mul(8).wrapping_add(octave as u32), u / cell, v / cell)
            } else {
                MEAN
            };
            value += weight * (0.5 + strength * (noise - 0.5));
        }
        value
    }

    /// [`Texture::sample`] of every textured texel of `texels`, written into its `value`: the
    /// same numbers bit for bit, computed over chunks of [`CHUNK`] neighbouring texels an octave
    /// at a time, each a loop without branches that the compiler turns into vector code. An
    /// octave too fine to show at any textured texel of a chunk is not computed there: far
    /// surfaces skip their fine octaves' noise, as the one-at-a-time sampler does.
    #[inline(always)]
    pub(crate) fn sample_batch(&self, texels: Texels<'_>) {
        let n = texels.value.len();
        let (material, u, v) = (&texels.material[..n], &texels.u[..n], &texels.v[..n]);
        let (footprint_m, textured, value) =
            (&texels.footprint_m[..n], &texels.textured[..n], &mut texels.value[..n]);
        for start in (0..n).step_by(CHUNK) {
            let chunk = start..n.min(start + CHUNK);
            if !textured[chunk.clone()].contains(&true) {
                continue;
            }
            // The bits of the smallest footprint textured; NaN and negative ones sort above
            // every positive one.
            let finest = footprint_m[chunk.clone()]
                .iter()
                .zip(&textured[chunk.clone()])
                .map(|(f, &textured)| if textured { f.to_bits() } else { u32::MAX })
                .fold(u32::MAX, u32::min);
            let hidden = self.shows_up_to_bits.iter().filter(|&&bits| finest > bits).count();
            self.sample_chunk(
                &material[chunk.clone()],
                &u[chunk.clone()],
                &v[chunk.clone()],
                &footprint_m[chunk.clone()],
                &mut value[chunk],
                hidden,
            );
        }
    }

    /// [`Texture::sample`] of each texel of a chunk into `value`, knowing that the first
    /// `hidden` octaves show at none of them.
    #[inline(always)]
    fn sample_chunk(
        &self,
        material: &[u32],
        u: &[f32],
        v: &[f32],
        footprint_m: &[f32],
        value: &mut [f32],
        hidden: usize,
    ) {
        let n = value.len();
        let (material, u, v, footprint_m) = (&material[..n], &u[..n], &v[..n], &footprint_m[..n]);
        value.fill(0.0);
        for (octave, (&cell, &weight)) in CELLS_M.iter().zip(&WEIGHTS).enumerate() {
            if octave < hidden {
                for i in 0..n {
                    let strength = octave_strength(cell, footprint_m[i]);
                    value[i] += weight * (0.5 + strength * (MEAN - 0.5));
                }
            } else {
                for i in 0..n {
                    let strength = octave_strength(cell, footprint_m[i]);
                    let layer = material[i].wrapping_mul(8).wrapping_add(octave as u32);
                    let noise = self.value_noise(layer, u[i] / cell, v[i] / cell);
                    // The reference's choice, made lane by lane: a select, not a branch.
                    let noise = if strength > 0.0 { noise } else { MEAN };
                    value[i] += weight * (0.5 + strength * (noise - 0.5));
                }
            }
        }
    }

    /// Smoothly interpolated lattice noise in [0, 1] at `(x, y)` (cells).
    #[inline(always)]
    fn value_noise(&self, layer: u32, x: f32, y: f32) -> f32 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (smooth(x - x0), smooth(y - y0));
        let (ix, iy) = (saturating_i32(x0), saturating_i32(y0));
        let at = |dx: i32, dy: i32| self.lattice(layer, ix.wrapping_add(dx), iy.wrapping_add(dy));
        let top = at(0, 0) + fx * (at(1, 0) - at(0, 0));
        let bottom = at(0, 1) + fx * (at(1, 1) - at(0, 1));
        top + fy * (bottom - top)
    }

    /// The value at a lattice point, in [0, 1].
    #[inline(always)]
    fn lattice(&self, layer: u32, ix: i32, iy: i32) -> f32 {
        let mut h = self.seed ^ layer.wrapping_mul(0x9E37_79B9);
        h ^= (ix as u32).wrapping_mul(0x85EB_CA6B);
        h = h.rotate_left(13).wrapping_mul(0xC2B2_AE35);
        h ^= (iy as u32).wrapping_mul(0x27D4_EB2F);
        h ^= h >> 15;
        h = h.wrapping_mul(0x2C1B_3C6D);
        h ^= h >> 12;
        h = h.wrapping_mul(0x297A_2D39);
        h ^= h >> 15;
        // Below 2²⁴, so exact as an i32 too, which converts to f32 in vector code.
        ((h >> 8) as i32) as f32 / (1u32 << 24) as f32
    }
}

/// Texels per chunk of [`Texture::sample_batch`]: a few vectors' worth, so that skipping an
/// octave is decided over pixels close enough to agree.
const CHUNK: usize = 16;

/// Surface points to texture, one per pixel of a row (structure of arrays, so
/// [`Texture::sample_batch`] vectorises), all slices as long.
pub(crate) struct Texels<'a> {
    /// Which surface ([`Surface::material`](crate::camera::scene::Surface)).
    pub(crate) material: &'a [u32],
    /// Surface coordinates (m).
    pub(crate) u: &'a [f32],
    pub(crate) v: &'a [f32],
    /// Footprint of the pixel on the surface (m), grown by the slant of the view.
    pub(crate) footprint_m: &'a [f32],
    /// Whether to texture the texel; the others' `value` is meaningless.
    pub(crate) textured: &'a [bool],
    /// Brightness, in [0, 1], once sampled.
    pub(crate) value: &'a mut [f32],
}

/// How much of an octave of `cell` metres shows at a pixel footprint of `footprint_m` metres:
/// 1 at [`FULL_STRENGTH_PX_PER_CELL`] pixels per cell or more, 0 at half that or fewer.
#[inline(always)]
fn octave_strength(cell: f32, footprint_m: f32) -> f32 {
    let px_per_cell = cell / footprint_m;
    ((px_per_cell - FULL_STRENGTH_PX_PER_CELL / 2.0) / (FULL_STRENGTH_PX_PER_CELL / 2.0)).clamp(0.0, 1.0)
}

/// The bits of the largest footprint (m) at which an octave of `cell` metres shows: over
/// non-negative floats, ordered as their bits are, it shows at +0 (infinitely many pixels per
/// cell), not at infinity, and at fewer as the footprint grows, so a bisection finds the edge.
fn largest_showing_footprint_bits(cell: f32) -> u32 {
    let shows = |bits: u32| octave_strength(cell, f32::from_bits(bits)) > 0.0;
    let (mut shown, mut hidden) = (0.0f32.to_bits(), f32::INFINITY.to_bits());
    while hidden - shown > 1 {
        let middle = shown + (hidden - shown) / 2;
        if shows(middle) {
            shown = middle;
        } else {
            hidden = middle;
        }
    }
    shown
}

/// `x as i32` (saturating, NaN to 0) in operations that vectorise: the saturating cast itself
/// is compiled lane by lane with branches, the truncating one to a single instruction.
#[inline(always)]
fn saturating_i32(x: f32) -> i32 {
    /// The largest `f32` below 2³¹.
    const BELOW_2_31: f32 = 2_147_483_520.0;
    let inside = if x.is_nan() { 0.0 } else { x.clamp(i32::MIN as f32, BELOW_2_31) };
    // SAFETY: `inside` is not NaN and lies in [-2³¹, 2³¹), so it truncates to an i32.
    let truncated = unsafe { inside.to_int_unchecked::<i32>() };
    if x >= 2_147_483_648.0 { i32::MAX } else { truncated }
}

/// Smoothstep, so the noise has no creases at cell borders.
#[inline(always)]
fn smooth(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn varies_up_close_and_fades_to_its_mean_far_away() {
        let t = Texture::new(7);
        let near: Vec<f32> = (0..200).map(|i| t.sample(0, i as f32 * 0.013, 0.3, 0.005)).collect();
        let (lo, hi) = near.iter().fold((1f32, 0f32), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        assert!(hi - lo > 0.3, "{lo}..{hi}");
        assert!(near.iter().all(|v| (0.0..=1.0).contains(v)));
        assert_eq!(t.sample(0, 12.3, 4.5, 100.0), 0.5);
        assert_eq!(t.sample(3, 1.0, 2.0, 0.01), Texture::new(7).sample(3, 1.0, 2.0, 0.01));
        assert_ne!(t.sample(3, 1.0, 2.0, 0.01), Texture::new(8).sample(3, 1.0, 2.0, 0.01));
    }

    /// A surface coordinate (m): mostly within a world, sometimes any float at all.
    fn coordinate() -> impl proptest::strategy::Strategy<Value = f32> {
        proptest::prop_oneof![9 => -1e4f32..1e4, 1 => proptest::num::f32::ANY]
    }

    /// A pixel footprint (m): mostly within a world's, in runs of one value as neighbouring
    /// pixels on one surface have, sometimes any float.
    fn footprint() -> impl proptest::strategy::Strategy<Value = f32> {
        proptest::prop_oneof![6 => 1e-4f32..10.0, 3 => proptest::sample::select(vec![0.005f32, 0.02, 0.1]), 1 => proptest::num::f32::ANY]
    }

    #[test]
    fn an_octave_shows_exactly_up_to_its_threshold() {
        let t = Texture::new(3);
        for (&cell, &bits) in CELLS_M.iter().zip(&t.shows_up_to_bits) {
            let edge = f32::from_bits(bits);
            for (f, shows) in [
                (edge, true),
                (edge.next_down(), true),
                (edge.next_up(), false),
                (0.0, true),
                (-0.0, false),
                (f32::NAN, false),
                (f32::INFINITY, false),
                (-1.0, false),
            ] {
                assert_eq!(octave_strength(cell, f) > 0.0, shows, "cell {cell} m, footprint {f} m");
                assert_eq!(f.to_bits() <= bits, shows, "cell {cell} m, footprint {f} m");
            }
        }
    }

    #[test]
    fn the_vectorising_cast_saturates_as_the_cast_does() {
        let edges = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            2_147_483_520.0,
            2_147_483_648.0,
            -2_147_483_648.0,
            -2_147_483_904.0,
            0.0,
            -0.0,
            -1.5,
            1.5,
            1e30,
            -1e30,
        ];
        for x in edges {
            assert_eq!(saturating_i32(x), x as i32, "{x}");
        }
    }

    proptest::proptest! {
        /// On random bit patterns: NaNs, infinities and subnormals among them.
        #[test]
        fn the_vectorising_cast_is_the_cast(bits in proptest::num::u32::ANY) {
            let x = f32::from_bits(bits);
            proptest::prop_assert_eq!(saturating_i32(x), x as i32);
        }

        /// The batch samples every texel as the one-at-a-time sampler does, bit for bit, from
        /// footprints where every octave shows to ones where none does, and at coordinates whose
        /// cells overflow.
        #[test]
        fn a_batch_samples_each_texel_as_one_at_a_time(
            texels in proptest::collection::vec(
                (0u32..100, coordinate(), coordinate(), footprint(), proptest::bool::weighted(0.9)),
                0..200,
            ),
        ) {
            let t = Texture::new(11);
            let column = |f: fn(&(u32, f32, f32, f32, bool)) -> f32| texels.iter().map(f).collect::<Vec<_>>();
            let material: Vec<u32> = texels.iter().map(|t| t.0).collect();
            let textured: Vec<bool> = texels.iter().map(|t| t.4).collect();
            let (u, v, footprint_m) = (column(|t| t.1), column(|t| t.2), column(|t| t.3));
            let mut values = vec![0.0; texels.len()];
            t.sample_batch(Texels { material: &material, u: &u, v: &v, footprint_m: &footprint_m, textured: &textured, value: &mut values });
            for (&(material, u, v, footprint_m, textured), &value) in texels.iter().zip(&values) {
                if !textured {
                    continue;
                }
                let one = t.sample(material, u, v, footprint_m);
                proptest::prop_assert!(value.to_bits() == one.to_bits() || (value.is_nan() && one.is_nan()), "{value} {one}");
            }
        }
    }
}
