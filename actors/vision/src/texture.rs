//! Invalidating disparities where the image has no texture to match.
//!
//! Semi-global matching fills a textureless patch with disparities propagated from its
//! borders; a plain wall then reads as whatever surrounds it (the thesis's failure, §4.2.3,
//! seen from the other side). A pixel whose neighbourhood has a mean horizontal gradient below
//! a threshold gets no disparity, so the grid reports the patch as invalid, not as free.
//!
//! The check is OpenCV's `Sobel` (1×3 central difference, scale ½, rounded to `CV_16S`),
//! `convertScaleAbs`, a normalised `boxFilter` to `CV_32F` and `compare(CMP_LT)`, all with
//! replicated borders, done here in integers in one pass over the image: that chain cost as much
//! as a third of the whole pipeline's overhead over the bare matcher. The OpenCV
//! chain stays as the reference the tests hold this one to, pixel for pixel.

use opencv::core::{CV_8UC1, Mat, MatTraitConst, MatTraitConstManual};
use serde::{Deserialize, Serialize};

use crate::disparity_map::DisparityMap;
use crate::error::{CvContext, VisionError};

/// When a pixel counts as textureless.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TextureParams {
    /// Smallest mean |∂I/∂x| over the window (grey levels per px) for a pixel to keep its
    /// disparity; 0 disables the check.
    pub min_gradient: f32,
    /// Side of the square window the gradient is averaged over (px, odd).
    pub window_px: u32,
}

impl Default for TextureParams {
    /// ¼ grey level per px over 15×15 px: a uniformly painted patch loses its disparities,
    /// while the faintly textured surfaces of the Middlebury scenes, which SGBM matches well,
    /// keep theirs (at 1 grey level per px teddy's bad-2 rose from 22 % to 33 %). Noisy
    /// textureless surfaces pass this check; SGBM's uniqueness and speckle checks catch most.
    fn default() -> Self {
        TextureParams { min_gradient: 0.25, window_px: 15 }
    }
}

/// Applies [`TextureParams`] to disparity maps; keeps its buffers across frames.
pub struct TextureFilter {
    params: TextureParams,
    /// A window's gradient sum (grey levels/px, summed over window_px² pixels) is textureless
    /// below this: the smallest sum whose mean OpenCV's `boxFilter` would not call below
    /// `min_gradient`.
    textured_sum: u32,
    /// |∂I/∂x| per pixel (grey levels per px, rounded as OpenCV's `Sobel` rounds).
    gradient: Vec<u8>,
    /// Per column: the gradient summed over the window's rows.
    column_sums: Vec<u32>,
    /// Running sums along one row of column sums, the window's half-width replicated at each
    /// end: a window's sum is the difference of two, so the compare runs over whole rows.
    prefix: Vec<u32>,
    /// 1 where textureless, else 0.
    mask: Vec<u8>,
}

impl TextureFilter {
    /// Checks the parameters; `None` when the check is disabled.
    pub fn new(params: &TextureParams) -> Result<Option<TextureFilter>, VisionError> {
        if !(params.min_gradient.is_finite() && params.min_gradient >= 0.0) {
            return Err(VisionError::Params(format!(
                "texture min_gradient {} must be ≥ 0",
                params.min_gradient
            )));
        }
        if params.window_px.is_multiple_of(2) || !(3..=31).contains(&params.window_px) {
            return Err(VisionError::Params(format!(
                "texture window_px {} must be odd in 3..=31",
                params.window_px
            )));
        }
        Ok((params.min_gradient > 0.0).then(|| TextureFilter {
            params: params.clone(),
            textured_sum: textured_sum(params.min_gradient, params.window_px),
            gradient: Vec::new(),
            column_sums: Vec::new(),
            prefix: Vec::new(),
            mask: Vec::new(),
        }))
    }

    /// Marks invalid every pixel of `disparity` whose neighbourhood in `image` (the matched
    /// left image, same size) is textureless.
    pub fn apply(&mut self, image: &Mat, disparity: &mut DisparityMap) -> Result<(), VisionError> {
        if (image.cols() as usize, image.rows() as usize) != (disparity.width, disparity.height) {
            return Err(VisionError::Input("texture image and disparity differ in size".into()));
        }
        for (d, &textureless) in disparity.values.iter_mut().zip(self.textureless(image)?) {
            if textureless != 0 {
                *d = f32::NAN;
            }
        }
        Ok(())
    }

    /// Per pixel of `image` (8-bit grey, row-major): non-zero where its neighbourhood is
    /// textureless. Valid until the next call.
    pub fn textureless(&mut self, image: &Mat) -> Result<&[u8], VisionError> {
        if image.typ() != CV_8UC1 {
            return Err(VisionError::Input(format!(
                "the texture check needs an 8-bit grey image, not OpenCV type {}",
                image.typ()
            )));
        }
        let (width, height) = (image.cols() as usize, image.rows() as usize);
        let pixels = image.data_bytes().cv("texture image pixels")?;
        if width == 0 || height == 0 {
            self.mask.clear();
            return Ok(&self.mask);
        }
        self.mask_of(pixels, width, height);
        Ok(&self.mask)
    }

    /// The mask of `pixels`, in the host's widest vector code: with AVX2 the loops over rows of
    /// gradients and sums run in vector lanes, which SSE2, x86-64's baseline, lacks the
    /// unsigned widening and compares for (they stayed scalar there).
    fn mask_of(&mut self, pixels: &[u8], width: usize, height: usize) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU was just seen to have AVX2, the one feature the function needs.
            unsafe { self.mask_of_avx2(pixels, width, height) };
            return;
        }
        self.mask_of_in(pixels, width, height);
    }

    /// [`TextureFilter::mask_of_in`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn mask_of_avx2(&mut self, pixels: &[u8], width: usize, height: usize) {
        self.mask_of_in(pixels, width, height);
    }

    /// The check, inlined into each instruction set's entry point.
    #[inline(always)]
    fn mask_of_in(&mut self, pixels: &[u8], width: usize, height: usize) {
        self.gradients(pixels, width, height);
        self.threshold(width, height);
    }

    /// |I(x+1) − I(x−1)| / 2 per pixel, borders replicated, with OpenCV's rounding: `Sobel`'s
    /// float result goes to `CV_16S` rounded half to even, so an odd difference 2k+1 becomes
    /// the even one of k and k+1.
    #[inline(always)]
    fn gradients(&mut self, pixels: &[u8], width: usize, height: usize) {
        self.gradient.resize(width * height, 0);
        // Wrapping arithmetic here and in the sums below only drops the overflow checks of
        // test builds, which kept these loops out of vector lanes: no value can overflow (a
        // half difference is at most 128, a window sum at most 128 · 31², a row's running sum
        // under 2²³).
        let half = |a: u8, b: u8| {
            let d = a.abs_diff(b);
            (d >> 1).wrapping_add(d & (d >> 1) & 1)
        };
        for (row, out) in pixels.chunks_exact(width).zip(self.gradient.chunks_exact_mut(width)) {
            if width == 1 {
                out[0] = 0;
                continue;
            }
            out[0] = half(row[1], row[0]);
            for ((o, &a), &b) in out[1..width - 1].iter_mut().zip(&row[2..]).zip(&row[..width - 2]) {
                *o = half(a, b);
            }
            out[width - 1] = half(row[width - 1], row[width - 2]);
        }
    }

    /// The mask: each pixel's window sum of gradients (rows, then columns, borders
    /// replicated) against [`TextureFilter::textured_sum`].
    #[inline(always)]
    fn threshold(&mut self, width: usize, height: usize) {
        let TextureFilter { params, textured_sum, gradient, column_sums, prefix, mask } = self;
        let radius = (params.window_px / 2) as usize;
        let row = |y: isize| -> &[u8] {
            let y = y.clamp(0, height as isize - 1) as usize;
            &gradient[y * width..][..width]
        };
        column_sums.clear();
        column_sums.resize(width, 0);
        for dy in -(radius as isize)..=radius as isize {
            slide(column_sums, row(dy), &[]);
        }
        mask.resize(width * height, 0);
        prefix.resize(width + 2 * radius + 1, 0);
        let window = 2 * radius + 1;
        for (y, out) in mask.chunks_exact_mut(width).enumerate() {
            let (left, right) = (column_sums[0], column_sums[width - 1]);
            let mut running = 0;
            for p in &mut prefix[1..=radius] {
                running = u32::wrapping_add(running, left);
                *p = running;
            }
            for (p, &v) in prefix[radius + 1..=radius + width].iter_mut().zip(column_sums.iter()) {
                running = running.wrapping_add(v);
                *p = running;
            }
            for p in &mut prefix[radius + width + 1..] {
                running = running.wrapping_add(right);
                *p = running;
            }
            below(out, &prefix[window..], &prefix[..width], *textured_sum);
            slide(column_sums, row((y + radius + 1) as isize), row(y as isize - radius as isize));
        }
    }
}

/// Adds `entering` to `sums` and takes `leaving` off (none when empty): the window's column
/// sums moving down a row.
#[inline(always)]
fn slide(sums: &mut [u32], entering: &[u8], leaving: &[u8]) {
    if leaving.is_empty() {
        for (sum, &g) in sums.iter_mut().zip(entering) {
            *sum = sum.wrapping_add(u32::from(g));
        }
    } else {
        for ((sum, &inn), &out) in sums.iter_mut().zip(entering).zip(leaving) {
            *sum = sum.wrapping_add(u32::from(inn)).wrapping_sub(u32::from(out));
        }
    }
}

/// `flags[x]` = 1 where the window sum `ends[x] − starts[x]` is below `threshold`.
#[inline(always)]
fn below(flags: &mut [u8], ends: &[u32], starts: &[u32], threshold: u32) {
    for ((flag, &end), &start) in flags.iter_mut().zip(ends).zip(starts) {
        *flag = u8::from(end.wrapping_sub(start) < threshold);
    }
}

/// The smallest window sum of gradients that OpenCV's normalised `boxFilter` (the sum times
/// 1/window², to `f32`) and `compare(CMP_LT)` against `min_gradient` would keep as textured.
/// The mean is monotone in the sum, so a search over the sums finds it once per parameter set.
fn textured_sum(min_gradient: f32, window_px: u32) -> u32 {
    let scale = 1.0 / f64::from(window_px * window_px);
    let textured = |sum: u32| (f64::from(sum) * scale) as f32 >= min_gradient;
    let (mut low, mut high) = (0, 128 * window_px * window_px + 1);
    while low < high {
        let middle = (low + high) / 2;
        if textured(middle) { high = middle } else { low = middle + 1 }
    }
    low
}

#[cfg(test)]
mod tests {
    use opencv::core::{
        BORDER_REPLICATE, CMP_LT, CV_16S, CV_32F, Mat, MatTraitConst, MatTraitConstManual, Point, Scalar,
        Size,
    };
    use opencv::imgproc;

    use super::{TextureFilter, TextureParams};
    use crate::image::gray_mat;

    /// OpenCV's chain, as the filter ran before it was done in integers: non-zero where
    /// textureless.
    fn opencv_mask(image: &Mat, params: &TextureParams) -> Vec<u8> {
        let (mut gradient, mut magnitude, mut mean, mut mask) =
            (Mat::default(), Mat::default(), Mat::default(), Mat::default());
        imgproc::sobel(image, &mut gradient, CV_16S, 1, 0, 1, 0.5, 0.0, BORDER_REPLICATE).unwrap();
        opencv::core::convert_scale_abs(&gradient, &mut magnitude, 1.0, 0.0).unwrap();
        let w = params.window_px as i32;
        imgproc::box_filter(
            &magnitude,
            &mut mean,
            CV_32F,
            Size::new(w, w),
            Point::new(-1, -1),
            true,
            BORDER_REPLICATE,
        )
        .unwrap();
        opencv::core::compare(&mean, &Scalar::all(f64::from(params.min_gradient)), &mut mask, CMP_LT)
            .unwrap();
        mask.data_bytes().unwrap().to_vec()
    }

    fn agree(pixels: &[u8], width: usize, height: usize, params: &TextureParams) {
        let image = gray_mat(pixels, width as u32, height as u32).unwrap();
        let mut filter = TextureFilter::new(params).unwrap().unwrap();
        let ours: Vec<bool> = filter.textureless(&image).unwrap().iter().map(|&f| f != 0).collect();
        let reference: Vec<bool> = opencv_mask(&image, params).iter().map(|&f| f != 0).collect();
        assert_eq!(ours, reference, "{width}×{height} {params:?}");
    }

    proptest::proptest! {
        /// Small images of faint texture (differences of a few grey levels, so the rounding of
        /// odd differences and thresholds near the sums decide) and of any contrast.
        #[test]
        fn the_integer_check_is_opencvs_chain(
            width in 1usize..40,
            height in 1usize..30,
            contrast in proptest::sample::select(vec![1u8, 3, 7, 255]),
            seed in proptest::num::u64::ANY,
            window in proptest::sample::select(vec![3u32, 5, 7, 15, 31]),
            min_gradient in proptest::sample::select(vec![0.1f32, 0.25, 0.5, 1.0, 1.0 / 3.0, 2.7]),
        ) {
            let mut state = seed | 1;
            let pixels: Vec<u8> = (0..width * height)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    100u8.saturating_add((state % (u64::from(contrast) + 1)) as u8)
                })
                .collect();
            agree(&pixels, width, height, &TextureParams { min_gradient, window_px: window });
        }
    }

    /// A VGA frame with flat patches beside textured ones, on the defaults.
    #[test]
    fn a_frame_with_flat_patches_is_masked_as_opencv_masks_it() {
        let (width, height) = (640, 480);
        let pixels: Vec<u8> = (0..width * height)
            .map(|i| {
                let (x, y) = (i % width, i / width);
                if (x / 80 + y / 60) % 2 == 0 { 128 } else { ((x * 7 + y * 13) % 5) as u8 * 3 + 90 }
            })
            .collect();
        agree(&pixels, width, height, &TextureParams::default());
    }

    /// A real photograph (Middlebury teddy), on the defaults and on the perception rig's window.
    #[test]
    fn a_photograph_is_masked_as_opencv_masks_it() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/middlebury2003_teddy/im2.png");
        let image = crate::image::load_gray(&path).unwrap();
        let (width, height) = (image.cols() as usize, image.rows() as usize);
        let pixels = image.data_bytes().unwrap().to_vec();
        for params in [TextureParams::default(), TextureParams { min_gradient: 1.0, window_px: 7 }] {
            agree(&pixels, width, height, &params);
        }
    }
}
