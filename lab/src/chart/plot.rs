//! The speed-against-accuracy figure of `occlux chart`: one panel per scene and lighting, log
//! time against log error; the fast methods' settings are points (the panel's Pareto front filled
//! and joined by a dashed staircase, the rest hollow), the path tracers lines with markers. Drawn
//! with plotters into an SVG and a PNG of the same layout, both written atomically.
//!
//! Fonts: the SVG's text is `<text>` elements that the viewer sets, so it needs no font file here
//! (its layout uses an estimate of text widths). The PNG's glyphs are rasterised by ab_glyph from
//! a TrueType font read at run time from the usual system places ([`FONT_PATHS`]); without one
//! the SVG is still written and the PNG fails with an error naming them.

use occlux::error::{Error, Result};
use occlux::export::atomic::write_bytes_atomic;
use occlux::export::png::write_rgb_png;
use occlux::font::{system_font, FONT_PATHS};
use plotters::coord::combinators::WithKeyPoints;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
// Qualified, not imported: `BackendStyle::stroke_width` would shadow `Color::stroke_width`.
use plotters_backend as backend;
use std::collections::HashMap;
use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

/// One panel: one scene under one lighting.
pub struct Panel {
    pub title: String,
    /// The fast methods' settings, each a point.
    pub points: Vec<PlotPoint>,
    /// Series drawn as lines with markers: the path tracers (e.g. "Cycles", "Occlux Monte Carlo")
    /// at increasing samples per pixel.
    pub curves: Vec<Curve>,
}

pub struct PlotPoint {
    /// The method's name (one colour and one legend entry per distinct series within the whole
    /// figure).
    pub series: String,
    /// The setting, e.g. "theta_deg = 50" (not drawn; the CSV has it).
    pub label: String,
    pub seconds: f64,
    pub error: f64,
    /// On the panel's Pareto front (no other point both faster and more accurate): drawn filled
    /// and joined by a dashed step line; others hollow.
    pub pareto: bool,
}

pub struct Curve {
    pub name: String,
    /// (seconds, error) in order of samples per pixel.
    pub points: Vec<(f64, f64)>,
}

/// One panel's size in pixels, legend column included.
const PANEL_SIZE: (u32, u32) = (640, 460);
/// Panels per row of the figure.
const COLUMNS: usize = 2;
/// The legend's column at the right of each panel: beside the plot rather than over it, so it
/// never hides a point whatever corner the data fills.
const LEGEND_WIDTH: u32 = 200;
const LEGEND_ROW: i32 = 22;
pub(crate) const FAMILY: &str = "sans-serif";
const TITLE_SIZE: f64 = 22.0;
const AXIS_DESC_SIZE: f64 = 16.0;
const TICK_SIZE: f64 = 13.0;
const LEGEND_SIZE: f64 = 14.0;
const NOTE_SIZE: f64 = 18.0;
const POINT_RADIUS: u32 = 4;
const CURVE_RADIUS: u32 = 3;
/// Matplotlib's "tab10": distinct hues that readers of plots already know.
const PALETTE: [RGBColor; 10] = [
    RGBColor(0x1f, 0x77, 0xb4),
    RGBColor(0xff, 0x7f, 0x0e),
    RGBColor(0x2c, 0xa0, 0x2c),
    RGBColor(0xd6, 0x27, 0x28),
    RGBColor(0x94, 0x67, 0xbd),
    RGBColor(0x8c, 0x56, 0x4b),
    RGBColor(0xe3, 0x77, 0xc2),
    RGBColor(0x7f, 0x7f, 0x7f),
    RGBColor(0xbc, 0xbd, 0x22),
    RGBColor(0x17, 0xbe, 0xcf),
];
/// The Pareto staircase: dark grey, not a series colour, since the front spans series.
const FRONT_COLOUR: RGBColor = RGBColor(0x30, 0x30, 0x30);

/// Draws every panel in a grid (2 columns; as many rows as needed), each with log10 axes
/// "time (s)" (x) and "relative RMSE" (y) spanning its own data with a margin, a title, and a
/// legend; writes `svg` and `png` atomically. Points or curve points with non-finite or
/// non-positive time or error are left out of the drawing (a panel with nothing drawable still
/// gets its title and a "no data" note).
///
/// The figure is [`figure_size`] pixels in both files. The SVG is written first and needs no
/// font; a failure on the PNG (no font found, a missing folder) leaves the complete SVG and no
/// PNG.
pub fn write_charts(panels: &[Panel], svg: &Path, png: &Path) -> Result<()> {
    if panels.is_empty() {
        return Err(Error::param("panels", "nothing to chart: no panels"));
    }
    let colours = SeriesColours::of(panels);
    let size = figure_size(panels.len());
    let svg_text = render_svg(panels, &colours, size, svg)?;
    write_bytes_atomic(svg, svg_text.as_bytes())?;
    if !png_font_registered() {
        return Err(missing_font_error(png));
    }
    let rgb = render_rgb(panels, &colours, size, png)?;
    write_rgb_png(png, &rgb, size)
}

/// The figure's size in pixels for `panels` panels: [`COLUMNS`] across (fewer when there are
/// fewer panels, so one panel is not half empty), as many rows as needed.
pub fn figure_size(panels: usize) -> (u32, u32) {
    let (rows, columns) = grid(panels);
    (PANEL_SIZE.0 * columns as u32, PANEL_SIZE.1 * rows as u32)
}

/// Rows and columns of the panel grid.
fn grid(panels: usize) -> (usize, usize) {
    let columns = panels.clamp(1, COLUMNS);
    (panels.div_ceil(columns).max(1), columns)
}

fn drawing_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::format(path, format!("drawing the chart: {e}"))
}

type DrawResult<DB> =
    std::result::Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// The figure as SVG text; errors name `path`, where it is going.
fn render_svg(
    panels: &[Panel],
    colours: &SeriesColours,
    size: (u32, u32),
    path: &Path,
) -> Result<String> {
    let mut text = String::new();
    let root = EstimatedText(SVGBackend::with_string(&mut text, size)).into_drawing_area();
    draw_figure(&root, panels, colours)
        .and_then(|()| root.present())
        .map_err(|e| drawing_error(path, e))?;
    // The backend borrows `text` until dropped; `present` has closed the SVG.
    drop(root);
    Ok(text)
}

/// The figure as 8-bit RGB pixels, row by row; errors name `path`, where it is going.
fn render_rgb(
    panels: &[Panel],
    colours: &SeriesColours,
    size: (u32, u32),
    path: &Path,
) -> Result<Vec<u8>> {
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
    draw_figure(&root, panels, colours)
        .and_then(|()| root.present())
        .map_err(|e| drawing_error(path, e))?;
    drop(root);
    Ok(rgb)
}

/// Whether the PNG has a font: registers the system font ([`occlux::font`]) as its sans-serif,
/// once per process (the answer is kept, found or not).
pub(crate) fn png_font_registered() -> bool {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    *REGISTERED.get_or_init(|| {
        system_font().is_some_and(|bytes| {
            plotters::style::register_font(FAMILY, FontStyle::Normal, bytes).is_ok()
        })
    })
}

fn missing_font_error(png: &Path) -> Error {
    Error::io(
        png,
        std::io::Error::new(
            std::io::ErrorKind::NotFound,
            format!(
                "no TrueType font for the chart's text (the SVG needs none and was written); \
                 tried {}; install one, e.g. `apt-get install fonts-dejavu-core` \
                 (Fedora: dejavu-sans-fonts)",
                FONT_PATHS.join(", ")
            ),
        ),
    )
}

/// Each series' colour, the same in every panel: colours in order of first appearance over the
/// panels (points before curves), cycling through [`PALETTE`] past ten series.
struct SeriesColours(HashMap<String, RGBColor>);

impl SeriesColours {
    fn of(panels: &[Panel]) -> Self {
        let mut map = HashMap::new();
        let names = panels.iter().flat_map(|p| {
            let points = p.points.iter().map(|pt| pt.series.as_str());
            points.chain(p.curves.iter().map(|c| c.name.as_str()))
        });
        for name in names {
            let next = PALETTE[map.len() % PALETTE.len()];
            map.entry(name.to_string()).or_insert(next);
        }
        SeriesColours(map)
    }

    fn get(&self, name: &str) -> RGBColor {
        self.0.get(name).copied().unwrap_or(BLACK)
    }
}

/// A value a log axis can show: finite and positive.
fn drawable(seconds: f64, error: f64) -> bool {
    seconds.is_finite() && seconds > 0.0 && error.is_finite() && error > 0.0
}

/// What of a panel gets drawn: its drawable points and curve points.
struct Drawn<'a> {
    points: Vec<&'a PlotPoint>,
    /// Curves with at least one drawable point, keeping only those points.
    curves: Vec<(&'a str, Vec<(f64, f64)>)>,
}

impl<'a> Drawn<'a> {
    fn of(panel: &'a Panel) -> Self {
        let points = panel
            .points
            .iter()
            .filter(|p| drawable(p.seconds, p.error))
            .collect();
        let curves = panel
            .curves
            .iter()
            .map(|c| {
                let kept = c.points.iter().copied().filter(|&(t, e)| drawable(t, e));
                (c.name.as_str(), kept.collect::<Vec<_>>())
            })
            .filter(|(_, pts)| !pts.is_empty())
            .collect();
        Drawn { points, curves }
    }

    fn is_empty(&self) -> bool {
        self.points.is_empty() && self.curves.is_empty()
    }

    fn all(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        let points = self.points.iter().map(|p| (p.seconds, p.error));
        points.chain(self.curves.iter().flat_map(|(_, pts)| pts.iter().copied()))
    }

    fn front(&self) -> Vec<(f64, f64)> {
        let front = self.points.iter().filter(|p| p.pareto);
        front.map(|p| (p.seconds, p.error)).collect()
    }
}

fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[Panel],
    colours: &SeriesColours,
) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    for (area, panel) in root.split_evenly(grid(panels.len())).iter().zip(panels) {
        draw_panel(area, panel, colours)?;
    }
    Ok(())
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
    colours: &SeriesColours,
) -> DrawResult<DB> {
    // A little air above the title, which plotters sets flush with the top.
    let body = area
        .margin(6, 0, 0, 0)
        .titled(&panel.title, (FAMILY, TITLE_SIZE))?;
    let drawn = Drawn::of(panel);
    if drawn.is_empty() {
        return draw_no_data(&body);
    }
    let width = body.dim_in_pixel().0;
    let (plot, legend) = body.split_horizontally(width.saturating_sub(LEGEND_WIDTH));
    draw_plot(&plot, &drawn, colours)?;
    draw_legend(&legend, &legend_entries(&drawn, colours))
}

fn draw_no_data<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
    let (w, h) = area.dim_in_pixel();
    let style = TextStyle::from((FAMILY, NOTE_SIZE).into_font())
        .color(&FRONT_COLOUR)
        .pos(Pos::new(HPos::Center, VPos::Center));
    area.draw_text("no data", &style, (w as i32 / 2, h as i32 / 2))
}

/// The axes, the front's staircase, the curves and the points, in that order so that markers
/// sit on top of lines.
fn draw_plot<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    drawn: &Drawn,
    colours: &SeriesColours,
) -> DrawResult<DB> {
    let x = log_span(drawn.all().map(|(t, _)| t));
    let y = log_span(drawn.all().map(|(_, e)| e));
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(log_axis(x), log_axis(y))?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc("relative RMSE")
        .x_label_formatter(&|v| tick_label(*v))
        .y_label_formatter(&|v| tick_label(*v))
        .axis_desc_style((FAMILY, AXIS_DESC_SIZE))
        .label_style((FAMILY, TICK_SIZE))
        .bold_line_style(BLACK.mix(0.15))
        .light_line_style(BLACK.mix(0.05))
        .draw()?;
    let front = FRONT_COLOUR.mix(0.7).stroke_width(1);
    chart.draw_series(std::iter::once(DashedPathElement::new(
        pareto_staircase(&drawn.front()),
        6,
        4,
        front,
    )))?;
    for (name, pts) in &drawn.curves {
        let colour = colours.get(name);
        chart.draw_series(LineSeries::new(pts.iter().copied(), colour.stroke_width(2)))?;
        let markers = pts
            .iter()
            .map(|&p| Circle::new(p, CURVE_RADIUS, colour.filled()));
        chart.draw_series(markers)?;
    }
    chart.draw_series(drawn.points.iter().map(|p| {
        let colour = colours.get(&p.series);
        // Filled on the front, hollow (a ring) off it.
        let style = if p.pareto {
            colour.filled()
        } else {
            colour.stroke_width(2)
        };
        Circle::new((p.seconds, p.error), POINT_RADIUS, style)
    }))?;
    Ok(())
}

/// The decades an axis spans: its values', widened on each side by 8% of the span and at least a
/// quarter decade, so that a single value or a tight cluster still gets an axis with ticks.
fn log_span(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v.log10()), hi.max(v.log10()))
    });
    let pad = ((hi - lo) * 0.08).max(0.25);
    10f64.powf(lo - pad)..10f64.powf(hi + pad)
}

/// A log10 axis over `span` with ticks from [`log_ticks`] and light grid lines at every
/// 1..9 × 10^k. plotters' own log ticks are only powers of ten (and their neighbours), which
/// leaves an axis spanning less than a decade without a single label.
fn log_axis(span: Range<f64>) -> WithKeyPoints<LogCoord<f64>> {
    let ticks = log_ticks(&span);
    let light = multiples_within(&span, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
    span.log_scale()
        .with_key_points(ticks)
        .with_light_points(light)
}

/// Labelled ticks: powers of ten when the span holds three or more, else 1-2-5 multiples, else
/// every 1..9 multiple; thinned to at most 8 so labels do not collide.
fn log_ticks(span: &Range<f64>) -> Vec<f64> {
    const STEPS: [&[f64]; 3] = [
        &[1.0],
        &[1.0, 2.0, 5.0],
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
    ];
    let ticks = STEPS
        .iter()
        .map(|m| multiples_within(span, m))
        .find(|t| t.len() >= 3)
        .unwrap_or_else(|| multiples_within(span, STEPS[2]));
    let stride = ticks.len().div_ceil(8).max(1);
    ticks.into_iter().step_by(stride).collect()
}

/// Every m × 10^k within `span` for m in `mantissas`, ascending.
fn multiples_within(span: &Range<f64>, mantissas: &[f64]) -> Vec<f64> {
    let first = span.start.log10().floor() as i32;
    let last = span.end.log10().ceil() as i32;
    let candidates = (first..=last).flat_map(|k| mantissas.iter().map(move |m| m * 10f64.powi(k)));
    // A tiny relative slack so that a tick equal to an end, give or take rounding, counts.
    let (lo, hi) = (span.start * (1.0 - 1e-9), span.end * (1.0 + 1e-9));
    candidates.filter(|v| (lo..=hi).contains(v)).collect()
}

/// A tick's text: plain decimals with up to three significant digits between 0.001 and 9999
/// ("0.002", "0.25", "40"), scientific outside ("1e-5", "2.5e4"); trailing zeros dropped.
fn tick_label(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return format!("{v}");
    }
    let decade = v.log10().floor();
    if (-3.0..4.0).contains(&decade) {
        let decimals = (2.0 - decade).max(0.0) as usize;
        trim_zeros(&format!("{v:.decimals$}")).to_string()
    } else {
        let text = format!("{v:.2e}");
        let (mantissa, exponent) = text.split_once('e').unwrap_or((&text, "0"));
        format!("{}e{exponent}", trim_zeros(mantissa))
    }
}

/// "0.2500" -> "0.25", "3.00" -> "3", "40" -> "40".
fn trim_zeros(number: &str) -> &str {
    if number.contains('.') {
        number.trim_end_matches('0').trim_end_matches('.')
    } else {
        number
    }
}

/// The dashed line through the front: by increasing time, each point's error holds until the
/// next point's time, then drops to its error; the boundary of what the front dominates.
fn pareto_staircase(front: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut sorted = front.to_vec();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut steps = Vec::with_capacity(sorted.len() * 2);
    for pair in sorted.windows(2) {
        steps.push(pair[0]);
        steps.push((pair[1].0, pair[0].1));
    }
    steps.extend(sorted.last());
    steps
}

/// How a legend entry's sample looks.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Sample {
    /// A filled marker: a series of points.
    Marker,
    /// A line through a marker: a curve.
    LineMarker,
    /// A dashed line: the Pareto front.
    Dashed,
}

struct LegendEntry {
    label: String,
    colour: RGBColor,
    sample: Sample,
}

/// A panel's legend: its point series in their order of first appearance in the panel, then its
/// curves, then the front when it has one.
fn legend_entries(drawn: &Drawn, colours: &SeriesColours) -> Vec<LegendEntry> {
    let mut entries: Vec<LegendEntry> = Vec::new();
    for p in &drawn.points {
        if !entries.iter().any(|e| e.label == p.series) {
            entries.push(LegendEntry {
                label: p.series.clone(),
                colour: colours.get(&p.series),
                sample: Sample::Marker,
            });
        }
    }
    entries.extend(drawn.curves.iter().map(|(name, _)| LegendEntry {
        label: name.to_string(),
        colour: colours.get(name),
        sample: Sample::LineMarker,
    }));
    if drawn.points.iter().any(|p| p.pareto) {
        entries.push(LegendEntry {
            label: "Pareto front (filled)".to_string(),
            colour: FRONT_COLOUR,
            sample: Sample::Dashed,
        });
    }
    entries
}

fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
) -> DrawResult<DB> {
    let style = TextStyle::from((FAMILY, LEGEND_SIZE).into_font())
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let text_x = 44;
    let room = area.dim_in_pixel().0.saturating_sub(text_x as u32 + 4);
    for (row, entry) in entries.iter().enumerate() {
        // Start level with the top of the plot (below the chart margin).
        let y = 24 + row as i32 * LEGEND_ROW;
        draw_sample(area, entry, (8, 36), y)?;
        let label = fit_label(area, &entry.label, &style, room)?;
        area.draw_text(&label, &style, (text_x, y))?;
    }
    Ok(())
}

/// A legend sample between `x.0` and `x.1` at height `y`.
fn draw_sample<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entry: &LegendEntry,
    (x0, x1): (i32, i32),
    y: i32,
) -> DrawResult<DB> {
    let centre = ((x0 + x1) / 2, y);
    match entry.sample {
        Sample::Marker => area.draw(&Circle::new(centre, POINT_RADIUS, entry.colour.filled())),
        Sample::LineMarker => {
            area.draw(&PathElement::new(
                vec![(x0, y), (x1, y)],
                entry.colour.stroke_width(2),
            ))?;
            area.draw(&Circle::new(centre, CURVE_RADIUS, entry.colour.filled()))
        }
        Sample::Dashed => area.draw(&DashedPathElement::new(
            vec![(x0, y), (x1, y)],
            6,
            4,
            entry.colour.mix(0.7).stroke_width(1),
        )),
    }
}

/// `label`, cut short with an ellipsis when it would run past `room` pixels (into the next
/// panel).
fn fit_label<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    label: &str,
    style: &TextStyle,
    room: u32,
) -> std::result::Result<String, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut chars: Vec<char> = label.chars().collect();
    let mut text = label.to_string();
    while area.estimate_text_size(&text, style)?.0 > room && chars.len() > 1 {
        chars.pop();
        text = chars.iter().collect::<String>() + "…";
    }
    Ok(text)
}

/// A backend whose text sizes are estimated rather than measured with a font, so that laying out
/// the SVG needs no font file (the viewer sets its `<text>` in its own sans-serif anyway).
/// Everything else passes through.
struct EstimatedText<B>(B);

/// A sans-serif's mean advance, in ems (DejaVu Sans and Arial are near 0.55-0.6 on mixed text).
const MEAN_ADVANCE_EM: f64 = 0.6;

impl<B: DrawingBackend> DrawingBackend for EstimatedText<B> {
    type ErrorType = B::ErrorType;

    fn estimate_text_size<S: backend::BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> std::result::Result<(u32, u32), backend::DrawingErrorKind<B::ErrorType>> {
        // plotters writes an SVG font-size of size / 1.24 pixels.
        let em = style.size() / 1.24;
        let width = em * MEAN_ADVANCE_EM * text.chars().count() as f64;
        Ok((width.ceil() as u32, em.ceil() as u32))
    }

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }
    fn ensure_prepared(
        &mut self,
    ) -> std::result::Result<(), backend::DrawingErrorKind<B::ErrorType>> {
        self.0.ensure_prepared()
    }
    fn present(&mut self) -> std::result::Result<(), backend::DrawingErrorKind<B::ErrorType>> {
        self.0.present()
    }
    fn draw_pixel(
        &mut self,
        point: backend::BackendCoord,
        color: backend::BackendColor,
    ) -> std::result::Result<(), backend::DrawingErrorKind<B::ErrorType>> {
        self.0.draw_pixel(point, color)
    }
    fn draw_line<S: backend::BackendStyle>(
        &mut self,
        from: backend::BackendCoord,
        to: backend::BackendCoord,
        style: &S,
    ) -> std::result::Result<(), backend::DrawingErrorKind<B::ErrorType>> {
        self.0.draw_line(from, to, style)
    }
    fn draw_rect<S: backend::BackendStyle>(
        &mut self,
        upper_left: backend::BackendCoord,
        bottom_right: backend::BackendCoord,
        style: &S,
        fill: bool,
    ) -> std::result::Result<(), backend::DrawingErrorKind<B::ErrorType>> {
        self.0.draw_rect(upper_left, bottom_right, style, fill)
    }
    fn draw_path<S: backend::BackendStyle, I: IntoIterator<Item = backend::BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> std::result::Result<(), backend::DrawingErrorKind<B::ErrorType>> {
        self.0.draw_path(path, style)
    }
    fn draw_circle<S: backend::BackendStyle>(
        &mut self,
        center: backend::BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> std::result::Result<(), backend::DrawingErrorKind<B::ErrorType>> {
        self.0.draw_circle(center, radius, style, fill)
    }
    fn fill_polygon<S: backend::BackendStyle, I: IntoIterator<Item = backend::BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> std::result::Result<(), backend::DrawingErrorKind<B::ErrorType>> {
        self.0.fill_polygon(vert, style)
    }
    fn draw_text<S: backend::BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: backend::BackendCoord,
    ) -> std::result::Result<(), backend::DrawingErrorKind<B::ErrorType>> {
        self.0.draw_text(text, style, pos)
    }
    fn blit_bitmap(
        &mut self,
        pos: backend::BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> std::result::Result<(), backend::DrawingErrorKind<B::ErrorType>> {
        self.0.blit_bitmap(pos, size, src)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(series: &str, seconds: f64, error: f64, pareto: bool) -> PlotPoint {
        PlotPoint {
            series: series.to_string(),
            label: format!("{series} @ {seconds}"),
            seconds,
            error,
            pareto,
        }
    }

    fn sample_panels() -> Vec<Panel> {
        vec![
            Panel {
                title: "engine, ambient".to_string(),
                points: vec![
                    point("DOS", 0.01, 0.30, true),
                    point("DOS", 0.02, 0.20, true),
                    point("DOS", 0.05, 0.25, false),
                    point("VAO", 0.004, 0.50, true),
                    point("VAO", 0.03, 0.40, false),
                ],
                curves: vec![Curve {
                    name: "Cycles".to_string(),
                    points: vec![(2.0, 0.2), (4.0, 0.1), (8.0, 0.05)],
                }],
            },
            Panel {
                title: "skull, sun".to_string(),
                points: vec![
                    point("DOS", 0.01, 0.1, true),
                    point("DOS", 0.02, 0.2, false),
                ],
                curves: vec![Curve {
                    name: "Occlux Monte Carlo".to_string(),
                    points: vec![(1.0, 0.3), (3.0, 0.1)],
                }],
            },
        ]
    }

    fn svg_of(panels: &[Panel]) -> String {
        let colours = SeriesColours::of(panels);
        let size = figure_size(panels.len());
        render_svg(panels, &colours, size, Path::new("test.svg")).unwrap()
    }

    /// The `<circle .../>` tags of an SVG.
    fn circles(svg: &str) -> Vec<&str> {
        svg.match_indices("<circle")
            .map(|(i, _)| &svg[i..i + svg[i..].find("/>").unwrap()])
            .collect()
    }

    /// The contents of the SVG's `<text>` elements.
    fn texts(svg: &str) -> Vec<&str> {
        svg.split("<text")
            .skip(1)
            .map(|t| t[t.find('>').unwrap() + 1..t.find("</text>").unwrap()].trim())
            .collect()
    }

    fn count_text(svg: &str, text: &str) -> usize {
        texts(svg).iter().filter(|t| **t == text).count()
    }

    fn hollow(svg: &str) -> usize {
        circles(svg)
            .iter()
            .filter(|c| c.contains(r#"fill="none""#))
            .count()
    }

    #[test]
    fn svg_has_titles_axes_one_marker_per_point_and_legends() {
        let svg = svg_of(&sample_panels());
        for (text, count) in [
            ("engine, ambient", 1),
            ("skull, sun", 1),
            ("time (s)", 2),
            ("relative RMSE", 2),
            // Legends: DOS, VAO and Cycles in the first panel, DOS and the Monte Carlo in the
            // second; a front in each.
            ("DOS", 2),
            ("VAO", 1),
            ("Cycles", 1),
            ("Occlux Monte Carlo", 1),
            ("Pareto front (filled)", 2),
        ] {
            assert_eq!(count_text(&svg, text), count, "{text}");
        }
        // Markers: 7 points + 5 curve points, plus one per legend series or curve (3 + 2).
        assert_eq!(circles(&svg).len(), 7 + 5 + 5);
        // Hollow exactly where off the front.
        assert_eq!(hollow(&svg), 3);
        let (w, h) = figure_size(2);
        assert!(
            svg.contains(&format!(r#"width="{w}" height="{h}""#)),
            "size"
        );
        assert_eq!((w, h), (2 * PANEL_SIZE.0, PANEL_SIZE.1));
    }

    #[test]
    fn a_series_keeps_its_colour_across_panels() {
        let colours = SeriesColours::of(&sample_panels());
        let names = ["DOS", "VAO", "Cycles", "Occlux Monte Carlo"];
        for (i, name) in names.iter().enumerate() {
            assert_eq!(colours.get(name), PALETTE[i], "{name}");
        }
    }

    #[test]
    fn non_finite_and_non_positive_values_are_left_out() {
        let mut panels = sample_panels();
        panels[0].points.push(point("DOS", f64::NAN, 0.1, true));
        panels[0].points.push(point("DOS", 0.1, 0.0, false));
        panels[0].points.push(point("VAO", -1.0, 0.1, false));
        panels[0]
            .points
            .push(point("VAO", 0.1, f64::INFINITY, false));
        panels[0].curves[0].points.push((f64::INFINITY, 0.01));
        panels[0].curves[0].points.insert(0, (1.0, f64::NAN));
        // Nothing drawable at all: the title and a note, no axes or legend.
        panels[1].points = vec![point("DOS", 0.0, 0.1, true)];
        panels[1].curves[0].points = vec![(f64::NAN, 1.0)];
        let svg = svg_of(&panels);
        // The first panel as before: 5 points, 3 curve points, 3 legend markers; the second none.
        assert_eq!(circles(&svg).len(), 5 + 3 + 3);
        assert_eq!(hollow(&svg), 2);
        assert_eq!(count_text(&svg, "skull, sun"), 1);
        assert_eq!(count_text(&svg, "no data"), 1);
        assert_eq!(count_text(&svg, "time (s)"), 1, "no axes without data");
        assert_eq!(
            count_text(&svg, "Occlux Monte Carlo"),
            0,
            "no legend without data"
        );
    }

    #[test]
    fn writes_svg_and_a_png_of_the_figure_size() {
        let dir = tempfile::tempdir().unwrap();
        let (svg, png) = (dir.path().join("c.svg"), dir.path().join("c.png"));
        let result = write_charts(&sample_panels(), &svg, &png);
        assert!(std::fs::read_to_string(&svg).unwrap().ends_with("</svg>\n"));
        if !png_font_registered() {
            // A machine without any of the fonts: the PNG's error says what to install.
            let err = result.unwrap_err().to_string();
            assert!(err.contains("fonts-dejavu-core"), "{err}");
            assert!(!png.exists());
            return;
        }
        result.unwrap();
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), figure_size(2));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        let pixels = buf[..info.buffer_size()].chunks(3);
        let ink = pixels.clone().filter(|p| p != &[255, 255, 255]).count();
        let total = pixels.count();
        assert!(
            ink > total / 100 && ink < total / 2,
            "{ink} of {total} inked"
        );
        // The first series' colour is there (its markers and legend sample).
        let blue = [PALETTE[0].0, PALETTE[0].1, PALETTE[0].2];
        assert!(buf.chunks(3).any(|p| p == blue));
    }

    #[test]
    fn a_missing_folder_errors_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("nope");
        let err = write_charts(
            &sample_panels(),
            &missing.join("c.svg"),
            &missing.join("c.png"),
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("nope") && err.contains("does not exist"),
            "{err}"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn no_panels_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let (svg, png) = (dir.path().join("c.svg"), dir.path().join("c.png"));
        assert!(write_charts(&[], &svg, &png).is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn missing_font_error_names_the_paths_and_the_package() {
        let err = missing_font_error(Path::new("out/c.png")).to_string();
        assert!(err.starts_with("out/c.png: "), "{err}");
        for path in FONT_PATHS {
            assert!(err.contains(path), "{path} not named: {err}");
        }
        assert!(err.contains("fonts-dejavu-core"), "{err}");
    }

    #[test]
    fn the_grid_has_two_columns() {
        assert_eq!(grid(1), (1, 1));
        assert_eq!(grid(2), (1, 2));
        assert_eq!(grid(3), (2, 2));
        assert_eq!(grid(6), (3, 2));
        assert_eq!(figure_size(3), (2 * PANEL_SIZE.0, 2 * PANEL_SIZE.1));
        assert_eq!(figure_size(1), PANEL_SIZE);
    }

    #[test]
    fn log_span_covers_the_data_with_a_margin() {
        let span = log_span([0.5, 0.001, 10.0].into_iter());
        // Four decades, widened by 8% of four decades on each side.
        assert!((span.start.log10() + 3.32).abs() < 1e-9, "{span:?}");
        assert!((span.end.log10() - 1.32).abs() < 1e-9, "{span:?}");
        // One value: a quarter decade either side.
        let span = log_span([0.2].into_iter());
        assert!(
            (span.end / span.start - 10f64.sqrt()).abs() < 1e-9,
            "{span:?}"
        );
    }

    #[test]
    fn log_ticks_label_every_axis() {
        // Wide: powers of ten only.
        assert_eq!(
            log_ticks(&(0.0005..20.0)),
            vec![0.001, 0.01, 0.1, 1.0, 10.0]
        );
        // Under two decades: 1-2-5.
        let ticks = log_ticks(&(0.15..3.0));
        assert_eq!(ticks.len(), 4, "{ticks:?}");
        assert!((ticks[0] - 0.2).abs() < 1e-12 && (ticks[3] - 2.0).abs() < 1e-12);
        // The narrowest span log_span makes still gets ticks.
        let narrow = log_span([0.31].into_iter());
        assert!(log_ticks(&narrow).len() >= 2, "{:?}", log_ticks(&narrow));
        // Very wide: thinned to at most 8.
        assert!(log_ticks(&(1e-9..1e9)).len() <= 8);
    }

    #[test]
    fn tick_labels_are_short() {
        let cases = [
            (0.001, "0.001"),
            (0.0025, "0.0025"),
            (0.30000000000000004, "0.3"),
            (1.0, "1"),
            (40.0, "40"),
            (5000.0, "5000"),
            (1e-5, "1e-5"),
            (2.5e4, "2.5e4"),
        ];
        for (v, text) in cases {
            assert_eq!(tick_label(v), text, "{v}");
        }
    }

    #[test]
    fn the_front_is_a_staircase_right_then_down() {
        let steps = pareto_staircase(&[(4.0, 0.1), (1.0, 0.5), (2.0, 0.2)]);
        let expected = [(1.0, 0.5), (2.0, 0.5), (2.0, 0.2), (4.0, 0.2), (4.0, 0.1)];
        assert_eq!(steps, expected);
        assert!(pareto_staircase(&[]).is_empty());
        assert_eq!(pareto_staircase(&[(1.0, 2.0)]), [(1.0, 2.0)]);
    }
}
