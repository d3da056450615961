//! Past the depth: a mask read for more frames than it holds, through the runtime.
//!
//! Each scalar mask is generated, encoded to a Unorm16 `.stbn` blob and read back with
//! [`stbn_runtime::Stbn`], as a renderer would. Every curve is
//! [`stbn_gen::analysis::running_mean`] of an integrand of [`Integrand::ALL`] over the values a
//! schedule gives each pixel frame after frame, and the error image after the last count is
//! measured with [`image_low_band`].
//!
//! Schedules: `wrap` (the mask's own `sample`, repeating every `depth` frames), `progressive`
//! (`Stbn::progressive`: R2 offsets per epoch, the chosen one), white noise, and the rejected
//! alternatives of [`Alternative`] on one mask (a second table, on the asymmetric integrands of
//! [`Probe`]). A third table reads N samples per pixel per frame ([`Many`]).

use std::f64::consts::PI;

use stbn_build_support::encode::encode_volume;
use stbn_gen::analysis::{Integrand, RunningMean, image_low_band, running_mean};
use stbn_gen::baselines::{golden_ratio_shift, white_noise};
use stbn_gen::{MaskSpec, Observer};
use stbn_runtime::{Compression, Encoding, OffsetStbn, SampleOffset, Stbn};

use super::{Knob, Plan, Section, size_name};
use crate::Result;
use crate::output::{Axis, Cell, Chart, Series, SeriesLabelPosition, Table};

/// Samples per pixel per frame of the [`Many`] rows.
const SAMPLES_PER_FRAME: u32 = 4;

/// The `.stbn` blob (Unorm16, uncompressed) of the `side × side × depth` scalar mask of `seed`,
/// encoded as `generate --format stbn` encodes a scalar mask (`encode_volume`), to read with
/// [`Stbn::from_bytes`].
fn scalar_blob(side: u32, depth: u32, seed: u64) -> Result<Vec<u8>> {
    let volume = stbn_gen::generate(&MaskSpec::new(side, side, depth, seed), Observer::default())?;
    Ok(encode_volume(&volume, Encoding::Unorm16, Compression::None))
}

/// Fills `out` (`width × height` values, row-major) with `view`'s frame `frame` as `f64`.
fn read_frame(view: &OffsetStbn<'_>, frame: u32, scratch: &mut [f32], out: &mut [f64]) {
    let written = view.fill_frame(frame, scratch);
    debug_assert_eq!(written, out.len());
    out.iter_mut()
        .zip(scratch.iter())
        .for_each(|(o, &v)| *o = f64::from(v));
}

/// `white_noise` for frame `frame` of a sequence seeded by `seed`: `slices × width × height`
/// independent uniform values, a different ChaCha8 stream seed per frame.
fn white_frame(width: usize, height: usize, slices: usize, seed: u64, frame: u32) -> Vec<f64> {
    white_noise(
        width,
        height,
        slices,
        seed.wrapping_add(u64::from(frame) << 32),
    )
}

/// The van der Corput radical inverse of `i` in base 2, in `[0, 1)`.
fn van_der_corput(i: u32) -> f64 {
    f64::from(i.reverse_bits()) / 4_294_967_296.0
}

/// `fract(v + shift)` for `v`, `shift` in `[0, 1)`.
fn shifted(v: f64, shift: f64) -> f64 {
    let s = v + shift;
    if s >= 1.0 { s - 1.0 } else { s }
}

/// Frame-sized buffers the fills reuse: `width × height` values each.
struct Buffers {
    /// What `fill_frame` writes.
    decoded: Vec<f32>,
    /// One sample per pixel, for the means of [`Many::fill`].
    values: Vec<f64>,
}

/// One value per pixel per frame: what a pixel reads at frame `t` past the mask's depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Schedule {
    /// Independent uniform values every frame (ChaCha8): the 1/√N reference.
    White,
    /// `Stbn::sample`: the mask's `depth` frames, repeated.
    Wrap,
    /// `Stbn::progressive`: epoch `e = t / depth` reads the mask at the `e`-th R2 offset.
    Progressive,
    /// A rejected alternative ([`Alternative`]).
    Rejected(Alternative),
}

/// Schedules measured against [`Schedule::Progressive`] and rejected (BENCHMARKS.md, "Past the
/// depth"). Each reads frame `t` of epoch `e = t / depth` as described.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Alternative {
    /// Cranley–Patterson rotation: the mask's frame `t mod depth` with every value shifted by
    /// `fract(e · φ⁻¹)` (golden ratio). Stratifies each pixel's values over the epochs, but
    /// the same shift for every pixel whitens the error image.
    GoldenShift,
    /// The same with the shift `vdc(e)`, the base-2 van der Corput point of the epoch: it also
    /// breaks the mask's temporal order (slower than progressive over the first epochs).
    VanDerCorputShift,
    /// The progressive view's value with the `vdc(e)` shift added.
    R2AndVanDerCorput,
    /// Toroidal offsets from a sunflower (Vogel) spiral: radius `√e` pixels, angle `e` times
    /// the golden angle `π(3 − √5)`, rounded. Neighbouring offsets give neighbouring pixels
    /// correlated epochs: the error moves to low spatial frequencies.
    Sunflower,
    /// Epochs in groups of four: group `c = e / 4` at the progressive view's offset of epoch
    /// `c`, member `k = e mod 4` one more pixel along x (`k & 1`) and y (`k >> 1`): a 2 × 2
    /// cluster of offsets.
    Clusters2x2,
    /// Epochs in pairs: pair `p = e / 2` at the progressive view's offset of epoch `p`, the
    /// odd member reading `1 − v` (antithetic).
    Antithetic,
}

impl Alternative {
    /// Every alternative, in table order.
    const ALL: [Alternative; 6] = [
        Alternative::GoldenShift,
        Alternative::VanDerCorputShift,
        Alternative::R2AndVanDerCorput,
        Alternative::Sunflower,
        Alternative::Clusters2x2,
        Alternative::Antithetic,
    ];
}

impl Schedule {
    /// The name in the tables.
    fn name(self) -> &'static str {
        match self {
            Schedule::White => "white noise",
            Schedule::Wrap => "wrap (sample)",
            Schedule::Progressive => "progressive (R2 epochs)",
            Schedule::Rejected(Alternative::GoldenShift) => "CP golden-ratio shift per epoch",
            Schedule::Rejected(Alternative::VanDerCorputShift) => "CP van der Corput shift",
            Schedule::Rejected(Alternative::R2AndVanDerCorput) => "R2 + van der Corput shift",
            Schedule::Rejected(Alternative::Sunflower) => "sunflower (local) offsets",
            Schedule::Rejected(Alternative::Clusters2x2) => "2×2 clusters of R2 offsets",
            Schedule::Rejected(Alternative::Antithetic) => "R2 + antithetic pairs",
        }
    }

    /// Fills `out` (one value in `[0, 1)` per pixel, row-major) with frame `t` of this schedule
    /// on `mask` (`seed` only for white noise).
    fn fill(self, mask: &Stbn<'_>, seed: u64, t: u32, scratch: &mut [f32], out: &mut [f64]) {
        let (w, h, depth) = (mask.width(), mask.height(), mask.depth());
        let epoch = t / depth;
        let progressive = mask.progressive();
        let at = |offset: SampleOffset, frame: u32, scratch: &mut [f32], out: &mut [f64]| {
            read_frame(&mask.offset(offset), frame, scratch, out);
        };
        match self {
            Schedule::White => {
                out.copy_from_slice(&white_frame(w as usize, h as usize, 1, seed, t));
            }
            Schedule::Wrap => at(SampleOffset::ZERO, t, scratch, out),
            Schedule::Progressive => read_frame(&progressive, t, scratch, out),
            Schedule::Rejected(alternative) => match alternative {
                Alternative::GoldenShift => {
                    at(SampleOffset::ZERO, t, scratch, out);
                    out.iter_mut()
                        .for_each(|v| *v = golden_ratio_shift(*v, u64::from(epoch)));
                }
                Alternative::VanDerCorputShift => {
                    at(SampleOffset::ZERO, t, scratch, out);
                    let shift = van_der_corput(epoch);
                    out.iter_mut().for_each(|v| *v = shifted(*v, shift));
                }
                Alternative::R2AndVanDerCorput => {
                    read_frame(&progressive, t, scratch, out);
                    let shift = van_der_corput(epoch);
                    out.iter_mut().for_each(|v| *v = shifted(*v, shift));
                }
                Alternative::Sunflower => {
                    let e = f64::from(epoch);
                    let (radius, angle) = (e.sqrt(), e * PI * (3.0 - 5f64.sqrt()));
                    let offset = SampleOffset {
                        x: (radius * angle.cos()).round() as i32,
                        y: (radius * angle.sin()).round() as i32,
                        frame: 0,
                    };
                    at(offset, t, scratch, out);
                }
                Alternative::Clusters2x2 => {
                    let (group, member) = (epoch / 4, epoch % 4);
                    let base = progressive.sample_offset_at(group * depth);
                    let offset = SampleOffset {
                        x: base.x + (member & 1) as i32,
                        y: base.y + (member >> 1) as i32,
                        frame: 0,
                    };
                    at(offset, t, scratch, out);
                }
                Alternative::Antithetic => {
                    read_frame(&progressive, (epoch / 2) * depth + t % depth, scratch, out);
                    if epoch % 2 == 1 {
                        out.iter_mut().for_each(|v| *v = 1.0 - *v);
                    }
                }
            },
        }
    }
}

/// N samples per pixel per frame, frame `f`, sample `i` in `0..N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Many {
    /// `mask.progressive().sample(x, y, N·f + i)`: N consecutive progressive frames.
    Consecutive,
    /// `mask.dimension(i).progressive().sample(x, y, f)`: one R2 dimension per sample.
    Dimensions,
    /// `mask.dimension(i).sample(x, y, f)`: dimensions, wrapping past the depth.
    WrapDimensions,
    /// N independent uniform values per frame.
    White,
}

impl Many {
    /// Every way, in table order.
    const ALL: [Many; 4] = [
        Many::Consecutive,
        Many::Dimensions,
        Many::WrapDimensions,
        Many::White,
    ];

    /// The name in the table.
    fn name(self) -> &'static str {
        match self {
            Many::Consecutive => "consecutive progressive frames",
            Many::Dimensions => "R2 dimensions (progressive)",
            Many::WrapDimensions => "R2 dimensions (wrap)",
            Many::White => "white noise",
        }
    }

    /// Fills `out` with each pixel's mean of `integrand` over its N samples of frame `f`.
    fn fill(
        self,
        mask: &Stbn<'_>,
        seed: u64,
        integrand: Integrand,
        f: u32,
        buffers: &mut Buffers,
        out: &mut [f64],
    ) {
        let Buffers { decoded, values } = buffers;
        let n = SAMPLES_PER_FRAME;
        let white = match self {
            Many::White => white_frame(
                mask.width() as usize,
                mask.height() as usize,
                n as usize,
                seed,
                f,
            ),
            _ => Vec::new(),
        };
        for i in 0..n {
            match self {
                Many::Consecutive => read_frame(&mask.progressive(), n * f + i, decoded, values),
                Many::Dimensions => {
                    read_frame(&mask.dimension(i).progressive(), f, decoded, values);
                }
                Many::WrapDimensions => read_frame(&mask.dimension(i), f, decoded, values),
                Many::White => {
                    let len = values.len();
                    values.copy_from_slice(&white[i as usize * len..][..len]);
                }
            }
            out.iter_mut()
                .zip(values.iter())
                .for_each(|(o, &v)| *o += integrand.eval(v) / f64::from(n));
        }
    }
}

/// An integrand of the curves: one of [`Integrand::ALL`], or an asymmetric one of the schedules
/// table. `Integrand::ALL` has symmetries that some rejected schedules integrate exactly
/// whatever the mask (`x + (1 − x)` and `[x < ½] + [1 − x < ½]` are constant, so antithetic
/// pairs have no ramp or step error; `[x < ½] + [x + ½ mod 1 < ½]` is constant, so a value
/// shift of ½ has no step error), which would hide how the schedules differ on other integrands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Probe {
    /// `stbn_gen::analysis`'s integrand.
    Analysis(Integrand),
    /// `[x < 0.37]`, `∫₀¹ = 0.37`: a step off the middle.
    StepAt037,
    /// `x²`, `∫₀¹ = 1/3`.
    Square,
    /// `sin²(πx)`, `∫₀¹ = 1/2`.
    SineSquared,
}

impl Probe {
    /// The integrands of the schedules table.
    const ASYMMETRIC: [Probe; 3] = [Probe::StepAt037, Probe::Square, Probe::SineSquared];

    /// `f(x)`.
    fn eval(self, x: f64) -> f64 {
        match self {
            Probe::Analysis(integrand) => integrand.eval(x),
            Probe::StepAt037 => f64::from(u8::from(x < 0.37)),
            Probe::Square => x * x,
            Probe::SineSquared => (PI * x).sin().powi(2),
        }
    }

    /// The exact `∫₀¹ f(x) dx`.
    fn integral(self) -> f64 {
        match self {
            Probe::Analysis(integrand) => integrand.integral(),
            Probe::StepAt037 => 0.37,
            Probe::Square => 1.0 / 3.0,
            Probe::SineSquared => 0.5,
        }
    }

    /// The name in the tables.
    fn name(self) -> &'static str {
        match self {
            Probe::Analysis(integrand) => integrand.name(),
            Probe::StepAt037 => "step 0.37",
            Probe::Square => "x²",
            Probe::SineSquared => "sin²(πx)",
        }
    }
}

/// `running_mean` of `integrand` over `frames` frames of `frame(t, out)` (unit values) on a
/// `side × side` image.
fn curve(
    side: u32,
    frames: &[usize],
    integrand: Probe,
    mut frame: impl FnMut(u32, &mut [f64]),
) -> RunningMean {
    let side = side as usize;
    running_mean(side, side, frames, integrand.integral(), |t, out| {
        frame(t, out);
        out.iter_mut().for_each(|v| *v = integrand.eval(*v));
    })
}

/// A table with a text column per name in `labels`, one RMSE column per count of `counts`
/// (`counts_name` in the headings) and the error's low band.
fn curve_table(labels: &[(&str, &str)], counts: &[usize], counts_name: &str) -> Table {
    let mut columns: Vec<(String, String, bool)> = labels
        .iter()
        .map(|&(csv, md)| (csv.to_owned(), md.to_owned(), false))
        .collect();
    columns.extend(counts.iter().map(|n| {
        (
            format!("rmse_{n}_{counts_name}"),
            format!("RMSE {n} {counts_name}"),
            true,
        )
    }));
    columns.push((
        "error_low_band".to_owned(),
        "error low band".to_owned(),
        true,
    ));
    let refs: Vec<(&str, &str, bool)> = columns
        .iter()
        .map(|(c, m, n)| (c.as_str(), m.as_str(), *n))
        .collect();
    Table::new(&refs)
}

/// The figure cells of a [`curve_table`] row: each RMSE, then the error's low band.
fn curve_cells(rmse: &[f64], low_band: Option<f64>) -> Vec<Cell> {
    let mut cells: Vec<Cell> = rmse.iter().map(|&e| Cell::sig(e, 3)).collect();
    cells.push(Cell::opt_fixed(low_band, 2));
    cells
}

/// One measured curve of the main table.
struct Row {
    depth: Option<u32>,
    schedule: Schedule,
    integrand: Probe,
    rmse: Vec<f64>,
    low_band: Option<f64>,
}

/// The past-depth knob: wrap, progressive and white noise on masks of every
/// `plan.past_depth_depths`, the rejected alternatives on the `plan.past_depth_alternatives`
/// mask, and N samples per pixel per frame on that mask.
pub fn past_depth(plan: &Plan) -> Result<Section> {
    let side = plan.past_depth_side;
    let frames = &plan.past_depth_frames;
    let pixels = (side * side) as usize;
    let mut blobs = Vec::new();
    for &depth in &plan.past_depth_depths {
        blobs.push((depth, scalar_blob(side, depth, plan.seed)?));
    }
    if !plan
        .past_depth_depths
        .contains(&plan.past_depth_alternatives)
    {
        let depth = plan.past_depth_alternatives;
        blobs.push((depth, scalar_blob(side, depth, plan.seed)?));
    }
    let mask_of = |depth: u32| -> Result<Stbn<'_>> {
        let (_, blob) = blobs
            .iter()
            .find(|(d, _)| *d == depth)
            .expect("every depth's blob is made above");
        Ok(Stbn::from_bytes(blob)
            .map_err(|e| format!("{}: {e}", size_name((side, side, depth))))?)
    };
    let mut buffers = Buffers {
        decoded: vec![0.0; pixels],
        values: vec![0.0; pixels],
    };

    let mut table = curve_table(
        &[
            ("mask", "mask"),
            ("schedule", "schedule"),
            ("integrand", "integrand"),
        ],
        frames,
        "frames",
    );
    let mut rows: Vec<Row> = Vec::new();
    let mut measure = |depth: Option<u32>,
                       schedule: Schedule,
                       integrands: &[Probe],
                       table: &mut Table,
                       rows: &mut Vec<Row>|
     -> Result<()> {
        let mask = mask_of(depth.unwrap_or(plan.past_depth_alternatives))?;
        let mask_name = depth.map_or("no mask".to_owned(), |d| size_name((side, side, d)));
        for &integrand in integrands {
            let result = curve(side, frames, integrand, |t, out| {
                schedule.fill(&mask, plan.seed, t, &mut buffers.decoded, out);
            });
            let low_band = image_low_band(side as usize, side as usize, &result.error);
            let mut row = vec![
                Cell::text(mask_name.clone()),
                Cell::text(schedule.name()),
                Cell::text(integrand.name()),
            ];
            row.extend(curve_cells(&result.rmse, low_band));
            table.push(row);
            rows.push(Row {
                depth,
                schedule,
                integrand,
                low_band,
                rmse: result.rmse,
            });
        }
        outln!("  {mask_name}: {}", schedule.name());
        Ok(())
    };
    let analysis = Integrand::ALL.map(Probe::Analysis);
    measure(None, Schedule::White, &analysis, &mut table, &mut rows)?;
    for &depth in &plan.past_depth_depths {
        for schedule in [Schedule::Wrap, Schedule::Progressive] {
            measure(Some(depth), schedule, &analysis, &mut table, &mut rows)?;
        }
    }
    let mut alternatives = curve_table(
        &[
            ("mask", "mask"),
            ("schedule", "schedule"),
            ("integrand", "integrand"),
        ],
        frames,
        "frames",
    );
    let mut alternative_rows = Vec::new();
    for schedule in [Schedule::White, Schedule::Wrap, Schedule::Progressive]
        .into_iter()
        .chain(Alternative::ALL.map(Schedule::Rejected))
    {
        // White noise reads no mask.
        measure(
            (schedule != Schedule::White).then_some(plan.past_depth_alternatives),
            schedule,
            &Probe::ASYMMETRIC,
            &mut alternatives,
            &mut alternative_rows,
        )?;
    }

    let sample_frames = &plan.past_depth_sample_frames;
    let mut many_table = curve_table(
        &[
            ("samples", "N samples per frame"),
            ("integrand", "integrand"),
        ],
        sample_frames,
        "frames",
    );
    let mut many_rows = Vec::new();
    let mask = mask_of(plan.past_depth_alternatives)?;
    for way in Many::ALL {
        for integrand in Integrand::ALL {
            let result = running_mean(
                side as usize,
                side as usize,
                sample_frames,
                integrand.integral(),
                |f, out| way.fill(&mask, plan.seed, integrand, f, &mut buffers, out),
            );
            let low_band = image_low_band(side as usize, side as usize, &result.error);
            let mut row = vec![Cell::text(way.name()), Cell::text(integrand.name())];
            row.extend(curve_cells(&result.rmse, low_band));
            many_table.push(row);
            many_rows.push((
                way,
                integrand,
                *result.rmse.last().expect("a count"),
                low_band,
            ));
        }
    }

    let findings = findings(plan, &rows, &alternative_rows, &many_rows);
    let chart = chart(plan, &rows);
    let depths: Vec<String> = plan.past_depth_depths.iter().map(u32::to_string).collect();
    Ok(Section {
        knob: Knob::PastDepth,
        title: "8. Past the depth: wrap against progressive reads".to_owned(),
        method: format!(
            "{side}×{side} scalar masks of {} frames, seed {}, encoded to Unorm16 `.stbn` blobs \
             and read through `stbn_runtime::Stbn`: **wrap** is `sample` (the mask's frames \
             repeated), **progressive** is `mask.progressive()` (epoch e = frame / depth read at \
             the e-th R2 offset), **white noise** independent values. Per pixel, the running \
             mean of an integrand (`stbn_gen::analysis::Integrand`: ramp x, step [x < ½], sine \
             sin πx) over frames 0..n (`stbn_gen::analysis::running_mean`); RMSE over pixels \
             against the exact integral; **error low band**: `spatial_low_band` of the error \
             image (mean − exact) after the last count, white noise = 1, lower is bluer. The \
             second table: the rejected schedules on the {} mask (each documented in \
             `tradeoff/progressive.rs`), on integrands without the symmetries that let \
             antithetic pairs or a value shift of ½ integrate ramp and step exactly: [x < 0.37], \
             x², sin²(πx). The third: {SAMPLES_PER_FRAME} samples per pixel per \
             frame on that mask; RMSE of the mean of the {SAMPLES_PER_FRAME}·F samples after F \
             frames.",
            depths.join(", "),
            plan.seed,
            size_name((side, side, plan.past_depth_alternatives)),
        ),
        tables: vec![
            (
                "past-depth".to_owned(),
                "Wrap, progressive and white noise.".to_owned(),
                table,
            ),
            (
                "past-depth_schedules".to_owned(),
                "Progressive (R2 epochs) against the rejected schedules.".to_owned(),
                alternatives,
            ),
            (
                "past-depth_samples".to_owned(),
                format!("{SAMPLES_PER_FRAME} samples per pixel per frame."),
                many_table,
            ),
        ],
        charts: vec![("past-depth".to_owned(), chart)],
        findings,
    })
}

/// The figures the section states: progressive on the shallowest mask against the deepest one,
/// the best schedules of `alternatives` on the step, and the lowest-RMSE way to take N samples
/// per frame.
fn findings(
    plan: &Plan,
    rows: &[Row],
    alternatives: &[Row],
    many: &[(Many, Integrand, f64, Option<f64>)],
) -> Vec<String> {
    let mut findings = Vec::new();
    let side = plan.past_depth_side;
    let (shallow, deep) = match (
        plan.past_depth_depths.first(),
        plan.past_depth_depths.last(),
    ) {
        (Some(&s), Some(&d)) if s < d => (s, d),
        _ => return findings,
    };
    let rmse = |depth: u32, schedule: Schedule, integrand: Probe| {
        rows.iter()
            .find(|r| r.depth == Some(depth) && r.schedule == schedule && r.integrand == integrand)
            .map(|r| r.rmse.clone())
    };
    let mut parts = Vec::new();
    let mut gains = Vec::new();
    for integrand in Integrand::ALL.map(Probe::Analysis) {
        let (Some(a), Some(b), Some(wrap)) = (
            rmse(shallow, Schedule::Progressive, integrand),
            rmse(deep, Schedule::Progressive, integrand),
            rmse(shallow, Schedule::Wrap, integrand),
        ) else {
            continue;
        };
        let ratios: Vec<f64> = plan
            .past_depth_frames
            .iter()
            .zip(a.iter().zip(&b))
            .filter(|(n, _)| **n >= deep as usize)
            .map(|(_, (x, y))| 100.0 * (x / y - 1.0))
            .collect();
        if let (Some(lo), Some(hi)) = (
            ratios.iter().copied().reduce(f64::min),
            ratios.iter().copied().reduce(f64::max),
        ) {
            parts.push(format!("{} {lo:+.1}% to {hi:+.1}%", integrand.name()));
        }
        if let (Some(w), Some(p)) = (wrap.last(), a.last()) {
            gains.push(format!("{} ×{:.1}", integrand.name(), w / p));
        }
    }
    let last = plan.past_depth_frames.last().copied().unwrap_or(0);
    if !parts.is_empty() {
        findings.push(format!(
            "Progressive {} against progressive {}, at every count ≥ {deep} frames (RMSE \
             change): {}.",
            size_name((side, side, shallow)),
            size_name((side, side, deep)),
            parts.join(", "),
        ));
    }
    if !gains.is_empty() {
        findings.push(format!(
            "Progressive against wrap on the {} mask after {last} frames (wrap RMSE / \
             progressive RMSE): {}.",
            size_name((side, side, shallow)),
            gains.join(", "),
        ));
    }
    let steps: Vec<&Row> = alternatives
        .iter()
        .filter(|r| r.integrand == Probe::StepAt037 && r.schedule != Schedule::White)
        .collect();
    let lowest_rmse = steps.iter().min_by(|a, b| {
        let last = |r: &Row| r.rmse.last().copied().unwrap_or(f64::INFINITY);
        last(a).total_cmp(&last(b))
    });
    let lowest_band = steps.iter().min_by(|a, b| {
        let band = |r: &Row| r.low_band.unwrap_or(f64::INFINITY);
        band(a).total_cmp(&band(b))
    });
    if let (Some(rmse), Some(band)) = (lowest_rmse, lowest_band) {
        findings.push(format!(
            "Schedules on the {} mask, step 0.37: lowest RMSE after {last} frames: {}; lowest error \
             low band: {}.",
            size_name((side, side, plan.past_depth_alternatives)),
            rmse.schedule.name(),
            band.schedule.name(),
        ));
    }
    for integrand in Integrand::ALL {
        let best = many
            .iter()
            .filter(|(way, i, ..)| *i == integrand && *way != Many::White)
            .min_by(|a, b| a.2.total_cmp(&b.2));
        if let Some((way, _, e, low_band)) = best {
            findings.push(format!(
                "{SAMPLES_PER_FRAME} samples per frame, {}: lowest RMSE after {} frames: {} \
                 ({e:.3e}, error low band {}).",
                integrand.name(),
                plan.past_depth_sample_frames.last().copied().unwrap_or(0),
                way.name(),
                low_band.map_or("n/a".to_owned(), |b| format!("{b:.2}")),
            ));
        }
    }
    findings
}

/// Step RMSE against frames of the main table's rows: white noise, and wrap and progressive on
/// every depth.
fn chart(plan: &Plan, rows: &[Row]) -> Chart {
    let series = rows
        .iter()
        .filter(|r| r.integrand == Probe::Analysis(Integrand::Step))
        .map(|r| Series {
            name: match r.depth {
                Some(d) => format!("{}, {d} frames", r.schedule.name()),
                None => r.schedule.name().to_owned(),
            },
            points: plan
                .past_depth_frames
                .iter()
                .zip(&r.rmse)
                .map(|(&n, &e)| (n as f64, e))
                .collect(),
            ..Series::default()
        })
        .collect();
    Chart {
        title: "Step RMSE of the running mean past the depth".to_owned(),
        x: Axis::log("frames"),
        y: Axis::log("step RMSE (lower is better)"),
        series,
        legend: SeriesLabelPosition::LowerLeft,
        reference: None,
    }
}
