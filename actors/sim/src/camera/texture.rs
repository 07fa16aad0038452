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

/// Seeded value noise.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Texture {
    seed: u32,
}

impl Texture {
    pub(crate) fn new(seed: u64) -> Texture {
        Texture { seed: (seed ^ (seed >> 32)) as u32 }
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
                0.5
            };
            value += weight * (0.5 + strength * (noise - 0.5));
        }
        value
    }

    /// [`Texture::sample`] of the first `n` texels of `texels`, written into their `value`:
    /// the same numbers bit for bit, computed an octave at a time over the whole batch with no
    /// branch, so the compiler turns each octave's loop into vector code. An octave at zero
    /// strength adds exactly `weight · 0.5` either way (its noise is finite), so computing its
    /// noise anyway changes nothing but the time.
    #[inline(always)]
    pub(crate) fn sample_batch(&self, texels: &mut Texels, n: usize) {
        let (material, u, v) = (&texels.material[..n], &texels.u[..n], &texels.v[..n]);
        let (footprint_m, value) = (&texels.footprint_m[..n], &mut texels.value[..n]);
        value.fill(0.0);
        for (octave, (&cell, &weight)) in CELLS_M.iter().zip(&WEIGHTS).enumerate() {
            for i in 0..n {
                let strength = octave_strength(cell, footprint_m[i]);
                let layer = material[i].wrapping_mul(8).wrapping_add(octave as u32);
                let noise = self.value_noise(layer, u[i] / cell, v[i] / cell);
                value[i] += weight * (0.5 + strength * (noise - 0.5));
            }
        }
    }

    /// Smoothly interpolated lattice noise in [0, 1] at `(x, y)` (cells).
    #[inline(always)]
    fn value_noise(&self, layer: u32, x: f32, y: f32) -> f32 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (smooth(x - x0), smooth(y - y0));
        let (ix, iy) = (x0 as i32, y0 as i32);
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

/// Surface points to texture (structure of arrays, so [`Texture::sample_batch`] vectorises),
/// as many entries as a row has columns; reused from row to row.
#[derive(Clone, Debug, Default)]
pub(crate) struct Texels {
    /// Which surface ([`Surface::material`](crate::camera::scene::Surface)).
    pub(crate) material: Vec<u32>,
    /// Surface coordinates (m).
    pub(crate) u: Vec<f32>,
    pub(crate) v: Vec<f32>,
    /// Footprint of the pixel on the surface (m), grown by the slant of the view.
    pub(crate) footprint_m: Vec<f32>,
    /// Brightness, in [0, 1], once sampled.
    pub(crate) value: Vec<f32>,
}

impl Texels {
    /// Room for `n` texels.
    pub(crate) fn resize(&mut self, n: usize) {
        self.material.resize(n, 0);
        for array in [&mut self.u, &mut self.v, &mut self.footprint_m, &mut self.value] {
            array.resize(n, 0.0);
        }
    }
}

/// How much of an octave of `cell` metres shows at a pixel footprint of `footprint_m` metres:
/// 1 at [`FULL_STRENGTH_PX_PER_CELL`] pixels per cell or more, 0 at half that or fewer.
#[inline(always)]
fn octave_strength(cell: f32, footprint_m: f32) -> f32 {
    let px_per_cell = cell / footprint_m;
    ((px_per_cell - FULL_STRENGTH_PX_PER_CELL / 2.0) / (FULL_STRENGTH_PX_PER_CELL / 2.0)).clamp(0.0, 1.0)
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

    proptest::proptest! {
        /// The batch samples every texel as the one-at-a-time sampler does, bit for bit, from
        /// footprints where every octave shows to ones where none does.
        #[test]
        fn a_batch_samples_each_texel_as_one_at_a_time(
            texels in proptest::collection::vec(
                (0u32..100, -1e4f32..1e4, -1e4f32..1e4, 1e-4f32..10.0),
                0..70,
            ),
        ) {
            let t = Texture::new(11);
            let mut batch = Texels::default();
            batch.resize(texels.len());
            for (i, &(material, u, v, footprint_m)) in texels.iter().enumerate() {
                (batch.material[i], batch.u[i], batch.v[i], batch.footprint_m[i]) = (material, u, v, footprint_m);
            }
            t.sample_batch(&mut batch, texels.len());
            for (&(material, u, v, footprint_m), &value) in texels.iter().zip(&batch.value) {
                proptest::prop_assert_eq!(value.to_bits(), t.sample(material, u, v, footprint_m).to_bits());
            }
        }
    }
}
