//! The rasterizer of a picture: a scene's prepared parts cut into bands
//! of sample rows drawn in parallel (depth-buffered triangles, lines,
//! translucent layers), and the resolve of a band's samples into sRGB
//! pixels (see the parent module).

use super::*;

/// Sample rows per band: the unit of parallel work. Each band owns its rows
/// of the buffers and draws, in the model's order, what overlaps them.
pub const BAND_ROWS: usize = 32;

/// A line in sample space; `bias` (in depth units) lets it win a near tie
/// with a surface it runs along.
#[derive(Clone, Copy)]
pub(super) struct Line {
    pub(super) a: Vec3,
    pub(super) b: Vec3,
    pub(super) color: [u16; 3],
    pub(super) bias: Bias,
}

/// A part's vertices in sample space (x right, y down, z larger = nearer,
/// all three in samples)
/// and their light, seen from the front and from behind.
pub(super) struct Prepared<'m> {
    pub(super) indices: Cow<'m, [u32]>,
    pub(super) screen: Vec<Vec3>,
    pub(super) front: Vec<Vec3>,
    pub(super) back: Vec<Vec3>,
    /// The material's opacity: 1 drawn opaque, less blended over what is
    /// behind (set after [`prepare`]).
    pub(super) alpha: f32,
}

/// What is drawn, in order: lines under the surfaces, the surfaces
/// (part, triangle), lines over them (index into the lines).
#[derive(Clone, Copy)]
pub(super) enum Item {
    Tri(u32, u32),
    Line(u32),
}

/// Everything a band draws from.
pub(super) struct Scene<'m> {
    pub(super) parts: Vec<Prepared<'m>>,
    pub(super) lines: Vec<Line>,
    pub(super) items: Vec<Item>,
}

impl Scene<'_> {
    /// A triangle's vertices, and their colours as seen from the side the
    /// camera is on (two-sided lighting: seen from behind, clockwise on the
    /// picture whose y points down, the normals are turned around).
    pub(super) fn triangle(&self, part: u32, tri: u32) -> Option<([Vec3; 3], [Vec3; 3], f32)> {
        let p = self.parts.get(part as usize)?;
        let t = p.indices.get(tri as usize * 3..tri as usize * 3 + 3)?;
        let i = [t[0] as usize, t[1] as usize, t[2] as usize];
        let v = [
            *p.screen.get(i[0])?,
            *p.screen.get(i[1])?,
            *p.screen.get(i[2])?,
        ];
        let lit = if edge(v[0], v[1], v[2].x, v[2].y) <= 0.0 {
            &p.front
        } else {
            &p.back
        };
        Some((v, [lit[i[0]], lit[i[1]], lit[i[2]]], p.alpha))
    }

    /// The sample rows an item may touch (inclusive; may lie outside the
    /// picture).
    pub(super) fn rows(&self, item: Item, thickness: f32) -> Option<(f32, f32)> {
        match item {
            Item::Tri(part, tri) => {
                let ([a, b, c], _, _) = self.triangle(part, tri)?;
                Some((a.y.min(b.y).min(c.y) - 1.0, a.y.max(b.y).max(c.y) + 1.0))
            }
            Item::Line(i) => {
                let l = self.lines.get(i as usize)?;
                Some((l.a.y.min(l.b.y) - thickness, l.a.y.max(l.b.y) + thickness))
            }
        }
    }
}

#[inline]
pub(super) fn edge(a: Vec3, b: Vec3, px: f32, py: f32) -> f32 {
    (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x)
}

#[inline]
pub(super) fn quantize(c: Vec3) -> [u16; 3] {
    let q = |x: f32| (x.clamp(0.0, 1.0) * 65535.0 + 0.5) as u16;
    [q(c.x), q(c.y), q(c.z)]
}

/// The rows `y0 .. y0 + rows` of the sample buffers.
pub(super) struct Band<'a> {
    pub(super) y0: usize,
    pub(super) rows: usize,
    pub(super) width: usize,
    pub(super) depth: &'a mut [f32],
    /// Linear RGB in 1/65535 units (premultiplied by `cover` where no
    /// opaque surface is: what translucent ones leave over the background).
    pub(super) color: &'a mut [[u16; 3]],
    /// How much of the sample translucent surfaces cover, in 1/65535, where
    /// no opaque one does (empty when the scene has no translucent part).
    pub(super) cover: &'a mut [u16],
    /// The depth and part (+1; 0 none) of the last translucent surface
    /// blended into the sample: a surface of the same part at the same
    /// depth (a disc's back face, which lies on its front face) is the
    /// same sheet and is not blended twice. Empty as `cover` is.
    pub(super) last: &'a mut [(f32, u16)],
}

impl Band<'_> {
    /// Fill a triangle's samples in this band, colours interpolated across
    /// it; `alpha` below 1 blends them over what is there (drawn after
    /// every opaque item, farthest first) and leaves the depth as it is.
    pub(super) fn triangle(&mut self, v: [Vec3; 3], c: [Vec3; 3], alpha: f32, part: u32) {
        let [a, mut b, mut c0] = v;
        let [ca, mut cb, mut cc] = c;
        if !(a.is_finite() && b.is_finite() && c0.is_finite()) {
            return;
        }
        let mut area = edge(a, b, c0.x, c0.y);
        if !(area.is_finite() && area.abs() > 1e-12) {
            return;
        }
        if area < 0.0 {
            std::mem::swap(&mut b, &mut c0);
            std::mem::swap(&mut cb, &mut cc);
            area = -area;
        }
        let inv = 1.0 / area;
        let w = self.width as f32;
        let (top, bottom) = (self.y0 as f32, (self.y0 + self.rows) as f32);
        let min_x = a.x.min(b.x).min(c0.x);
        let max_x = a.x.max(b.x).max(c0.x);
        let min_y = a.y.min(b.y).min(c0.y);
        let max_y = a.y.max(b.y).max(c0.y);
        if max_x < 0.0 || max_y < top || min_x >= w || min_y >= bottom {
            return;
        }
        // Samples sit at pixel centres (i + 0.5); both bounds are >= 0
        // here, so `as` rounds down.
        let x0 = (min_x - 0.5).max(0.0) as usize;
        let x1 = ((max_x - 0.5).max(0.0) as usize).min(self.width - 1);
        let y0 = ((min_y - 0.5).max(top)) as usize;
        let y1 = ((max_y - 0.5).max(0.0) as usize).min(self.y0 + self.rows - 1);
        if x1 < x0 || y1 < y0 {
            return;
        }
        // Each edge function is linear in x along a row: the samples inside
        // all three form one span, found per row, so a long thin triangle
        // (a tube's side seen at an angle) costs its samples, not its
        // bounding box.
        let edges = [(b, c0), (c0, a), (a, b)];
        // Along a row each edge function and the depth change by a constant
        // per sample: stepped, not recomputed.
        let dw = [-(c0.y - b.y), -(a.y - c0.y), -(b.y - a.y)];
        let dz = (dw[0] * a.z + dw[1] * b.z + dw[2] * c0.z) * inv;
        for y in y0..=y1 {
            let py = y as f32 + 0.5;
            let (mut lo, mut hi) = (x0 as f32 + 0.5, x1 as f32 + 0.5);
            for (p, q) in edges {
                // w(px) = k * px + m
                let k = -(q.y - p.y);
                let m = (q.x - p.x) * (py - p.y) + (q.y - p.y) * p.x;
                if k > 0.0 {
                    lo = lo.max(-m / k);
                } else if k < 0.0 {
                    hi = hi.min(-m / k);
                } else if m < 0.0 {
                    hi = f32::NEG_INFINITY;
                }
            }
            if lo.partial_cmp(&hi).is_none_or(|o| o.is_gt()) {
                continue;
            }
            // One sample of slack either side for rounding; the edge test
            // below decides. (Both are >= 0, so `as` rounds down.)
            let xs = (lo - 1.5).max(x0 as f32) as usize;
            let xe = (hi + 0.5).min(x1 as f32) as usize;
            let px = xs as f32 + 0.5;
            let mut w0 = edge(b, c0, px, py);
            let mut w1 = edge(c0, a, px, py);
            let mut w2 = edge(a, b, px, py);
            let mut z = (w0 * a.z + w1 * b.z + w2 * c0.z) * inv;
            let row = (y - self.y0) * self.width;
            if alpha < 1.0 {
                // A sample on the edge two triangles share can fall just
                // outside both by rounding: harmless when opaque (what is
                // behind shows at one sample), a missing layer when not.
                // Translucent triangles take a sliver more (a 1e-4 of
                // their size); the same sheet is blended once (`blend`).
                let slack = -1e-4 * area;
                for k in row + xs..=row + xe {
                    if w0 >= slack && w1 >= slack && w2 >= slack && z > self.depth[k] {
                        let (l0, l1, l2) = (w0 * inv, w1 * inv, w2 * inv);
                        self.blend(k, ca * l0 + cb * l1 + cc * l2, alpha, (z, part));
                    }
                    w0 += dw[0];
                    w1 += dw[1];
                    w2 += dw[2];
                    z += dz;
                }
                continue;
            }
            for (depth, color) in self.depth[row + xs..=row + xe]
                .iter_mut()
                .zip(&mut self.color[row + xs..=row + xe])
            {
                if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 && z > *depth {
                    *depth = z;
                    let (l0, l1, l2) = (w0 * inv, w1 * inv, w2 * inv);
                    *color = quantize(ca * l0 + cb * l1 + cc * l2);
                }
                w0 += dw[0];
                w1 += dw[1];
                w2 += dw[2];
                z += dz;
            }
        }
    }

    /// Sample `k` seen through a translucent surface of colour `src` and
    /// opacity `alpha` (`src` over what is there; over the background,
    /// the colour stays premultiplied by the coverage it adds to).
    #[inline]
    pub(super) fn blend(&mut self, k: usize, src: Vec3, alpha: f32, (z, part): (f32, u32)) {
        // Part + 1 (0: none); parts past u16 are not told apart.
        let tag = u16::try_from(part.saturating_add(1)).unwrap_or(u16::MAX);
        if let Some(last) = self.last.get_mut(k) {
            let same_sheet = last.1 == tag && (z - last.0).abs() <= 1e-5 * z.abs().max(1.0);
            if same_sheet {
                return;
            }
            *last = (z, tag);
        }
        let old = self.color[k].map(|c| f32::from(c) / 65535.0);
        let old = Vec3::from_array(old);
        self.color[k] = quantize(src * alpha + old * (1.0 - alpha));
        if let Some(c) = self.cover.get_mut(k) {
            let old = f32::from(*c) / 65535.0;
            *c = ((alpha + old * (1.0 - alpha)).clamp(0.0, 1.0) * 65535.0 + 0.5) as u16;
        }
    }

    /// A line's samples in this band, `thickness` samples wide across its
    /// major axis, depth-tested.
    pub(super) fn line(&mut self, l: &Line, thickness: usize) {
        let (a, b) = (l.a, l.b);
        let d = b - a;
        let steps = d.x.abs().max(d.y.abs()).ceil().max(1.0);
        if !steps.is_finite() || steps > 1e7 {
            return;
        }
        let n = steps as usize;
        let half = thickness as f32 * 0.5;
        // The steps whose samples can fall in this band.
        let (top, bottom) = (
            self.y0 as f32 - half - 1.0,
            (self.y0 + self.rows) as f32 + half + 1.0,
        );
        // The part of the line (0..1 along it) within [lo, hi] on one axis.
        let within = |start: f32, delta: f32, lo: f32, hi: f32| -> Option<(f32, f32)> {
            if delta == 0.0 {
                (start >= lo && start <= hi).then_some((0.0, 1.0))
            } else {
                let t0 = (lo - start) / delta;
                let t1 = (hi - start) / delta;
                Some((t0.min(t1), t0.max(t1)))
            }
        };
        // Rows of this band, columns of the picture: a line running far
        // outside the picture (a perspective camera's reaches the guard
        // band, a picture size beyond it) costs only the steps that can
        // land in it.
        let (Some((ty0, ty1)), Some((tx0, tx1))) = (
            within(a.y, d.y, top, bottom),
            within(a.x, d.x, -half - 1.0, self.width as f32 + half + 1.0),
        ) else {
            return;
        };
        let (t0, t1) = (ty0.max(tx0).max(0.0), ty1.min(tx1).min(1.0));
        if t0.partial_cmp(&t1).is_none_or(|o| o.is_gt()) {
            return;
        }
        let (k0, k1) = (
            ((t0 * steps).floor().max(0.0) as usize).min(n),
            ((t1 * steps).ceil().max(0.0) as usize).min(n),
        );
        let along_x = d.x.abs() >= d.y.abs();
        // Depth per sample along the major axis (0 for a line seen end on).
        let d_major = if along_x { d.x } else { d.y };
        let slope = if d_major == 0.0 { 0.0 } else { d.z / d_major };
        for k in k0..=k1 {
            let t = k as f32 / steps;
            let p = a + d * t;
            let (major, minor) = if along_x { (p.x, p.y) } else { (p.y, p.x) };
            if major < 0.0 {
                continue;
            }
            let m = major as usize;
            // The depth at the sample's centre along the major axis.
            let z = p.z + slope * (m as f32 + 0.5 - major);
            let bias = match l.bias {
                Bias::Flat(b) => b,
                Bias::Perspective(scale) => scale * (z + 1.0) * (z + 1.0),
            };
            let lo = (minor - half + 0.5).floor();
            for j in 0..thickness {
                let o = lo + j as f32;
                if o < 0.0 {
                    continue;
                }
                let o = o as usize;
                let (x, y) = if along_x { (m, o) } else { (o, m) };
                if x >= self.width || y < self.y0 || y >= self.y0 + self.rows {
                    continue;
                }
                let i = (y - self.y0) * self.width + x;
                if z + bias > self.depth[i] {
                    self.depth[i] = z;
                    self.color[i] = l.color;
                }
            }
        }
    }
}

/// A band's rows of [`Band::cover`] and [`Band::last`].
pub(super) type TranslucentRows<'a> = (&'a mut [u16], &'a mut [(f32, u16)]);

/// The sample buffers, drawn band by band in parallel.
pub(super) struct Target {
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) depth: Vec<f32>,
    /// Linear RGB in 1/65535 units.
    pub(super) color: Vec<[u16; 3]>,
    /// [`Band::cover`]: empty until a translucent part is drawn.
    pub(super) cover: Vec<u16>,
    /// [`Band::last`]: as `cover`.
    pub(super) last: Vec<(f32, u16)>,
}

impl Target {
    pub(super) fn new(width: usize, height: usize) -> Target {
        Target {
            width,
            height,
            depth: vec![f32::NEG_INFINITY; width * height],
            color: vec![[0; 3]; width * height],
            cover: Vec::new(),
            last: Vec::new(),
        }
    }

    /// Draw the scene's items in order. Each band draws the items that
    /// overlap it, in the same order, into rows no other band touches: the
    /// result is the same for any number of threads.
    pub(super) fn draw(&mut self, scene: &Scene<'_>, thickness: usize) {
        let bands = self.height.div_ceil(BAND_ROWS);
        let mut bins: Vec<Vec<u32>> = vec![Vec::new(); bands];
        let last = bands as f32 - 1.0;
        for (i, &item) in scene.items.iter().enumerate() {
            let Some((lo, hi)) = scene.rows(item, thickness as f32) else {
                continue;
            };
            if !(lo.is_finite() && hi.is_finite()) || hi < 0.0 || lo > self.height as f32 {
                continue;
            }
            let b0 = (lo.max(0.0) / BAND_ROWS as f32).min(last) as usize;
            let b1 = (hi.max(0.0) / BAND_ROWS as f32).min(last) as usize;
            for bin in &mut bins[b0..=b1] {
                bin.push(i as u32);
            }
        }
        let width = self.width;
        let height = self.height;
        if scene.parts.iter().any(|p| p.alpha < 1.0) {
            self.cover = vec![0; width * height];
            self.last = vec![(0.0, 0); width * height];
        }
        // Without translucent parts each band gets empty slices.
        let translucent: Vec<TranslucentRows<'_>> = if self.cover.is_empty() {
            (0..bands).map(|_| Default::default()).collect()
        } else {
            self.cover
                .chunks_mut(BAND_ROWS * width)
                .zip(self.last.chunks_mut(BAND_ROWS * width))
                .collect()
        };
        self.depth
            .par_chunks_mut(BAND_ROWS * width)
            .zip(self.color.par_chunks_mut(BAND_ROWS * width))
            .zip(translucent)
            .zip(bins.par_iter())
            .enumerate()
            .for_each(|(k, (((depth, color), (cover, last)), bin))| {
                let y0 = k * BAND_ROWS;
                let mut band = Band {
                    y0,
                    rows: BAND_ROWS.min(height - y0),
                    width,
                    depth,
                    color,
                    cover,
                    last,
                };
                for &i in bin {
                    match scene.items[i as usize] {
                        Item::Tri(part, tri) => {
                            if let Some((v, c, alpha)) = scene.triangle(part, tri) {
                                band.triangle(v, c, alpha, part);
                            }
                        }
                        Item::Line(l) => {
                            if let Some(l) = scene.lines.get(l as usize) {
                                band.line(l, thickness);
                            }
                        }
                    }
                }
            });
    }
}

pub(crate) fn srgb(linear: f32) -> u8 {
    let x = linear.clamp(0.0, 1.0);
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// [`srgb`] of every linear value in 1/65535 units (the buffers' unit).
pub(super) fn srgb_table() -> Vec<u8> {
    (0..=u16::MAX)
        .map(|i| srgb(f32::from(i) / 65535.0))
        .collect()
}

/// Average each pixel's samples (in linear light) and encode as sRGB.
pub(super) fn resolve(
    target: &Target,
    width: usize,
    height: usize,
    s: usize,
    transparent: bool,
) -> Image {
    let table = srgb_table();
    let encode = |c: u32| table[c.min(65535) as usize];
    let mut rgba = Vec::with_capacity(width * height * 4);
    let n = (s * s) as u32;
    for y in 0..height {
        let t = if height > 1 {
            y as f32 / (height - 1) as f32
        } else {
            0.0
        };
        let bg =
            quantize(Vec3::from_array(BACKGROUND_TOP).lerp(Vec3::from_array(BACKGROUND_BOTTOM), t))
                .map(u32::from);
        for x in 0..width {
            let mut sum = [0u32; 3];
            let mut covered = 0u32;
            // Samples only translucent surfaces cover: their premultiplied
            // colour and their coverage (1/65535), summed.
            let mut part = [0u64; 3];
            let mut part_cover = 0u64;
            let mut part_samples = 0u32;
            for sy in 0..s {
                let row = (y * s + sy) * target.width + x * s;
                for i in row..row + s {
                    let c = target.color[i];
                    if target.depth[i] > f32::NEG_INFINITY {
                        sum[0] += u32::from(c[0]);
                        sum[1] += u32::from(c[1]);
                        sum[2] += u32::from(c[2]);
                        covered += 1;
                    } else if let Some(&k) = target.cover.get(i)
                        && k > 0
                    {
                        for (p, c) in part.iter_mut().zip(c) {
                            *p += u64::from(c);
                        }
                        part_cover += u64::from(k);
                        part_samples += 1;
                    }
                }
            }
            // Rounded averages, in the buffers' 1/65535 units.
            let px = if part_samples > 0 {
                resolve_translucent(
                    (sum, covered),
                    (part, part_cover, part_samples),
                    n,
                    bg,
                    transparent,
                )
                .map(|(rgb, a)| [encode(rgb[0]), encode(rgb[1]), encode(rgb[2]), a])
                .unwrap_or([0; 4])
            } else if transparent {
                if covered == 0 {
                    [0, 0, 0, 0]
                } else {
                    let avg = |v: u32| encode((v + covered / 2) / covered);
                    let a = ((covered * 255 + n / 2) / n) as u8;
                    [avg(sum[0]), avg(sum[1]), avg(sum[2]), a]
                }
            } else {
                let rest = n - covered;
                let avg = |v: u32, b: u32| encode((v + b * rest + n / 2) / n);
                [
                    avg(sum[0], bg[0]),
                    avg(sum[1], bg[1]),
                    avg(sum[2], bg[2]),
                    255,
                ]
            };
            rgba.extend_from_slice(&px);
        }
    }
    Image {
        width: width as u32,
        height: height as u32,
        rgba,
        transparent,
    }
}

/// A pixel some of whose samples only translucent surfaces cover: its
/// linear colour (1/65535 units) and alpha, from the opaque samples'
/// colour sum and count, the translucent ones' premultiplied colour sum,
/// coverage sum (1/65535 each) and count, out of `n` samples. Over the
/// background `bg`, or with `transparent` unpremultiplied with the alpha
/// the coverage gives (`None`: nothing covers the pixel).
pub(super) fn resolve_translucent(
    (sum, covered): ([u32; 3], u32),
    (part, part_cover, part_samples): ([u64; 3], u64, u32),
    n: u32,
    bg: [u32; 3],
    transparent: bool,
) -> Option<([u32; 3], u8)> {
    pub(super) const ONE: u64 = 65535;
    let n = u64::from(n);
    // Premultiplied colour and coverage over all samples, in 1/65535².
    let colour = |k: usize| u64::from(sum[k]) * ONE + part[k] * ONE;
    let cover = u64::from(covered) * ONE + part_cover;
    if transparent {
        if cover == 0 {
            return None;
        }
        let avg = |k: usize| ((colour(k) + cover / 2) / cover) as u32;
        let a = ((cover * 255 + n * ONE / 2) / (n * ONE)) as u8;
        Some(([avg(0), avg(1), avg(2)], a))
    } else {
        // The background shows through what the samples leave uncovered.
        let empty = n - u64::from(covered) - u64::from(part_samples);
        let through = empty * ONE + (u64::from(part_samples) * ONE - part_cover);
        let avg =
            |k: usize| ((colour(k) + u64::from(bg[k]) * through + n * ONE / 2) / (n * ONE)) as u32;
        Some(([avg(0), avg(1), avg(2)], 255))
    }
}
