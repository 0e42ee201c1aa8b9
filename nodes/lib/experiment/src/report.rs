//! The run report: per trial PNG plots (plotters) with the data behind each as CSV beside it,
//! and one static `index.html` with the run's metadata, a summary table that fits a laptop
//! screen, and comparison tables (the thesis's numbers beside ours), so it opens anywhere
//! without a server.
//!
//! A plot shows what its title and legend say: a series without data gets no legend entry (a
//! note under the plot names the topic that was missing), a plot with no data at all is not
//! drawn (the page says so), and a non-negative quantity is drawn from 0 up, never below.

use std::fmt::Write as _;
use std::path::Path;
use std::sync::OnceLock;

use plotters::prelude::*;
pub use plotters::style::RGBColor;

use crate::error::{Error, Result};
use crate::judge::{INTERACTION_AREA_M, ObservedState, Series, THESIS_MIN_DISTANCE_M};
use crate::plan::Variant;

/// One trial of the report: a title, its summary row and its series.
#[derive(Debug, Clone)]
pub struct ReportTrial {
    /// Heading, e.g. `stacking-hri seed 3 (fded)`.
    pub title: String,
    /// Summary columns (name, value), the same names for every trial.
    pub row: Vec<(String, String)>,
    /// Time series.
    pub series: Series,
}

/// The facts of a run a reader needs to repeat it, shown at the top of the report: (name,
/// value) in order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Metadata {
    /// (name, value).
    pub entries: Vec<(String, String)>,
}

impl Metadata {
    /// What this process knows of itself: the cowork version, the git commit (the build's
    /// `COWORK_GIT_COMMIT` if set, else the working tree's at report time, "unknown" outside
    /// a checkout), the command line and the date (UTC).
    pub fn of_this_run() -> Self {
        let command: Vec<String> = std::env::args().map(|a| shell_word(&a)).collect();
        Self::default()
            .with("cowork version", env!("CARGO_PKG_VERSION"))
            .with("git commit", git_commit())
            .with("command line", command.join(" "))
            .with("date", utc(std::time::SystemTime::now()))
    }

    /// Adds `name: value`.
    #[must_use]
    pub fn with(mut self, name: impl Into<String>, value: impl Into<String>) -> Self {
        self.entries.push((name.into(), value.into()));
        self
    }
}

/// A table of the report besides the summary, e.g. the thesis's numbers beside ours.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    /// Caption: what is compared, with units and where the reference numbers come from.
    pub caption: String,
    /// Column headers.
    pub header: Vec<String>,
    /// Rows, as many cells as headers.
    pub rows: Vec<Vec<String>>,
}

/// What the report says above its trials.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReportHead {
    /// Page title.
    pub title: String,
    /// The run's metadata.
    pub meta: Metadata,
    /// Tables after the summary.
    pub tables: Vec<Table>,
}

impl From<&str> for ReportHead {
    /// A head with `title` and [`Metadata::of_this_run`].
    fn from(title: &str) -> Self {
        Self { title: title.to_owned(), meta: Metadata::of_this_run(), tables: Vec::new() }
    }
}

/// Summary column: the largest tool speed while a person was in the interaction area.
pub const NEAR_PERSON_SPEED: &str = "tool max, person < 0.8 m (m/s)";
/// Summary column: the speed α_h allowed at that moment.
pub const NEAR_PERSON_ALLOWED: &str = "α_h then (m/s)";
/// Summary column: the true robot–person distance at that moment.
pub const NEAR_PERSON_DISTANCE: &str = "person then (m)";

/// The summary columns of the tool's fastest moment near the person (the three
/// `NEAR_PERSON_*` names; "-" where the person never came that close while the tool moved).
pub fn near_person_columns(s: &Series) -> Vec<(String, String)> {
    let peak = s.fastest_near_person(INTERACTION_AREA_M);
    let f = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:.3}"));
    vec![
        (NEAR_PERSON_SPEED.into(), f(peak.map(|p| p.speed_m_s))),
        (NEAR_PERSON_ALLOWED.into(), f(peak.and_then(|p| p.allowed_m_s))),
        (NEAR_PERSON_DISTANCE.into(), f(peak.map(|p| p.person_distance_m))),
    ]
}

/// The person of a trial in words, for the metadata: height, side, when they walk in, where
/// and how fast they reach.
pub fn describe_person(v: &Variant) -> String {
    let targets: Vec<String> = v.reach_targets.iter().map(|r| format!("({:.2}, {:.2}, {:.2})", r[0], r[1], r[2])).collect();
    let speeds: Vec<String> = v.reach_speeds_m_s.iter().map(|s| format!("{s:.2}")).collect();
    format!(
        "{:.2} m tall, works from the {} side, walks in at {:.1} s, reaches to {} m (base frame) at up to {} m/s",
        v.body_height_m,
        v.side,
        v.enter_s,
        if targets.is_empty() { "-".into() } else { targets.join(", ") },
        if speeds.is_empty() { "-".into() } else { speeds.join(", ") }
    )
}

/// Environment variable naming a TrueType font for the plots' text.
pub const FONT_ENV: &str = "COWORK_REPORT_FONT";

/// Fonts tried when [`FONT_ENV`] is unset (Debian `fonts-dejavu-core`, `fonts-liberation`).
const FONT_CANDIDATES: [&str; 4] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
];

fn report_err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Report {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Registers the plots' font once (plotters draws text with ab_glyph from a font file).
fn ensure_font() -> Result<()> {
    static FONT: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let env = std::env::var(FONT_ENV).ok();
        let candidates: Vec<String> =
            env.iter().cloned().chain(FONT_CANDIDATES.iter().map(|s| (*s).to_owned())).collect();
        for c in &candidates {
            if let Ok(bytes) = std::fs::read(c) {
                // Registered fonts live as long as the process.
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    return Ok(());
                }
            }
        }
        Err(format!(
            "no TrueType font for the plots (tried {}); install fonts-dejavu-core or set {FONT_ENV}",
            candidates.join(", ")
        ))
    })
    .clone()
    .map_err(|message| Error::Report { path: "font".into(), message })
}

/// A line of (t, y) samples with its legend. A non-finite y is a gap in the line.
#[derive(Debug, Clone)]
pub struct Line<'a> {
    /// Legend.
    pub name: &'a str,
    /// (time s, value) samples.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: RGBColor,
}

impl Line<'_> {
    fn has_data(&self) -> bool {
        self.points.iter().any(|p| p.0.is_finite() && p.1.is_finite())
    }
}

/// How a plot's y axis is laid out.
#[derive(Debug, Clone, Copy)]
enum YAxis<'a> {
    /// Linear over the data and the marks. With a floor the axis starts exactly there and
    /// data below it is drawn at it (a non-negative quantity: floor 0).
    Linear { floor: Option<f64> },
    /// Named rows at y = 0, 1, 2, … (states and flags).
    Rows(&'a [&'a str]),
}

/// The y range: data and marks, padded by 5 % above, and below unless a floor is given (then
/// from the floor exactly); rows: half a row around them.
fn y_range(lines: &[Line<'_>], marks: &[(f64, &str)], axis: YAxis<'_>) -> (f64, f64) {
    let floor = match axis {
        YAxis::Rows(names) => return (-0.5, names.len().max(1) as f64 - 0.5),
        YAxis::Linear { floor } => floor,
    };
    let values = lines
        .iter()
        .flat_map(|l| l.points.iter().filter(|p| p.0.is_finite()).map(|p| p.1))
        .chain(marks.iter().map(|m| m.0))
        .filter(|y| y.is_finite());
    let (mut y0, mut y1) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| (a.min(y), b.max(y)));
    if !y0.is_finite() {
        (y0, y1) = (0.0, 1.0);
    }
    if let Some(f) = floor {
        y0 = f;
        y1 = y1.max(f);
    }
    if y1 - y0 < 1e-9 {
        y1 = y0 + 1.0;
    }
    let pad = 0.05 * (y1 - y0);
    (if floor.is_some() { y0 } else { y0 - pad }, y1 + pad)
}

/// The x range of the lines with data (s).
fn t_range(lines: &[Line<'_>]) -> (f64, f64) {
    let (mut t0, mut t1) = lines
        .iter()
        .flat_map(|l| l.points.iter().filter(|p| p.1.is_finite()).map(|p| p.0))
        .filter(|t| t.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| (a.min(t), b.max(t)));
    if !t0.is_finite() {
        (t0, t1) = (0.0, 1.0);
    }
    if t1 - t0 < 1e-6 {
        t1 = t0 + 1.0;
    }
    (t0, t1)
}

/// Runs of consecutive finite samples (a non-finite y ends a run).
fn runs(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut run = Vec::new();
    for &(t, y) in points {
        if t.is_finite() && y.is_finite() {
            run.push((t, y));
        } else if !run.is_empty() {
            out.push(std::mem::take(&mut run));
        }
    }
    if !run.is_empty() {
        out.push(run);
    }
    out
}

/// Draws `lines` (those with data) and horizontal `marks` into the PNG `path` (900 × 320, the
/// legend under it) and the drawn values into `path` with extension `csv`; returns the legend,
/// in order (the lines with data, then the marks).
fn draw(
    path: &Path,
    title: &str,
    y_label: &str,
    lines: &[Line<'_>],
    marks: &[(f64, &str)],
    axis: YAxis<'_>,
    span: Option<(f64, f64)>,
) -> Result<Vec<String>> {
    ensure_font()?;
    // What is drawn: lines with data, clamped at the floor.
    let floor = match axis {
        YAxis::Linear { floor } => floor,
        YAxis::Rows(_) => None,
    };
    let shown: Vec<Line<'_>> = lines
        .iter()
        .filter(|l| l.has_data())
        .map(|l| Line {
            // Not `y.max(f)`: that would turn a gap (NaN) into the floor.
            points: l.points.iter().map(|&(t, y)| (t, floor.map_or(y, |f| if y < f { f } else { y }))).collect(),
            ..l.clone()
        })
        .collect();
    let (t0, t1) = span.filter(|(a, b)| a.is_finite() && b.is_finite() && b - a > 1e-6).unwrap_or_else(|| t_range(&shown));
    let (y0, y1) = y_range(&shown, marks, axis);
    // The legend goes under the chart, one entry a line, so that it never hides data.
    let entries = shown.len() + marks.len();
    let legend_h = if entries == 0 { 0 } else { 8 + 18 * entries as u32 };
    // Drawn into a temporary beside the PNG (same extension: plotters picks the format from
    // it) and renamed onto it once whole, so a failed report never leaves a half-drawn PNG.
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!("{}{}-{name}", cowork_store::TEMP_PREFIX, std::process::id()));
    let legend = match draw_png(&tmp, path, title, y_label, &shown, marks, (t0, t1), (y0, y1), axis, legend_h) {
        Ok(legend) => legend,
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
    };
    std::fs::rename(&tmp, path).map_err(|e| report_err(path, e))?;
    let mut columns: Vec<(&str, Vec<(f64, f64)>)> =
        shown.iter().map(|l| (l.name, l.points.clone())).collect();
    columns.extend(marks.iter().map(|&(y, name)| (name, vec![(t0, y), (t1, y)])));
    let csv = path.with_extension("csv");
    cowork_store::write_atomic(&csv, csv_table(&columns).as_bytes()).map_err(|e| report_err(&csv, e))?;
    Ok(legend)
}

/// The PNG of [`draw`] into `tmp` (errors name `path`); the backend is dropped (and the file
/// closed) before it returns.
#[allow(clippy::too_many_arguments)]
fn draw_png(
    tmp: &Path,
    path: &Path,
    title: &str,
    y_label: &str,
    shown: &[Line<'_>],
    marks: &[(f64, &str)],
    (t0, t1): (f64, f64),
    (y0, y1): (f64, f64),
    axis: YAxis<'_>,
    legend_h: u32,
) -> Result<Vec<String>> {
    let root = BitMapBackend::new(tmp, (900, 320 + legend_h)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| report_err(path, e))?;
    let (top, bottom) = root.split_vertically(320);
    let mut chart = ChartBuilder::on(&top)
        .caption(title, ("sans-serif", 17))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(if matches!(axis, YAxis::Rows(_)) { 150 } else { 60 })
        .build_cartesian_2d(t0..t1, y0..y1)
        .map_err(|e| report_err(path, e))?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc("simulated time (s)").y_desc(y_label).label_style(("sans-serif", 13));
    // Rows: as many labels as rows puts plotters' ticks on the integers; each is named.
    let name = |y: &f64| match axis {
        YAxis::Rows(names) if (y - y.round()).abs() < 1e-6 && *y >= 0.0 => {
            names.get(y.round() as usize).map_or(String::new(), |n| (*n).to_owned())
        }
        _ => String::new(),
    };
    if let YAxis::Rows(names) = axis {
        mesh.y_labels(names.len()).y_label_formatter(&name);
    }
    mesh.draw().map_err(|e| report_err(path, e))?;
    // (name, colour, stroke width; 0: a dot).
    let mut legend: Vec<(String, RGBColor, u32)> = Vec::new();
    for l in shown {
        let color = l.color;
        let mut dot = true;
        for run in runs(&l.points) {
            // A lone sample is a dot: a line through one point draws nothing. Otherwise one
            // path per segment: plotters joins a wide polyline with mitres, which at a sharp
            // spike reach far past the data (below 0 under a speed's dip to 0).
            if run.len() == 1 {
                chart.draw_series(run.iter().map(|&p| Circle::new(p, 4, color.filled())))
            } else {
                dot = false;
                chart.draw_series(run.windows(2).map(|w| PathElement::new(vec![w[0], w[1]], color.stroke_width(2))))
            }
            .map_err(|e| report_err(path, e))?;
        }
        legend.push((l.name.to_owned(), color, if dot { 0 } else { 2 }));
    }
    let red = RGBColor(255, 0, 0);
    for &(y, name) in marks {
        chart
            .draw_series(LineSeries::new([(t0, y), (t1, y)], red.stroke_width(1)))
            .map_err(|e| report_err(path, e))?;
        legend.push((name.to_owned(), red, 1));
    }
    for (k, (name, color, width)) in legend.iter().enumerate() {
        let y = 4 + 18 * k as i32 + 9;
        if *width == 0 {
            bottom.draw(&Circle::new((85, y), 4, color.filled())).map_err(|e| report_err(path, e))?;
        } else {
            bottom
                .draw(&PathElement::new(vec![(70, y), (100, y)], color.stroke_width(*width)))
                .map_err(|e| report_err(path, e))?;
        }
        bottom
            .draw(&Text::new(name.clone(), (110, y - 8), ("sans-serif", 13).into_font().color(&BLACK)))
            .map_err(|e| report_err(path, e))?;
    }
    root.present().map_err(|e| report_err(path, e))?;
    Ok(legend.into_iter().map(|l| l.0).collect())
}

/// A CSV field, quoted when it needs to be.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// `t` and one column per series: a row per distinct time (a second row at the same time
/// where a series steps there); empty cells where a series has no sample or a gap.
fn csv_table(columns: &[(&str, Vec<(f64, f64)>)]) -> String {
    let mut out = String::from("t");
    for (name, _) in columns {
        out.push(',');
        out.push_str(&csv_field(name));
    }
    out.push('\n');
    let mut samples: Vec<(f64, usize, f64)> = columns
        .iter()
        .enumerate()
        .flat_map(|(c, (_, p))| p.iter().filter(|s| s.0.is_finite()).map(move |&(t, y)| (t, c, y)))
        .collect();
    // Stable: a series' own order is kept at equal times.
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut row: Option<(f64, Vec<Option<f64>>)> = None;
    let flush = |out: &mut String, (t, cells): (f64, Vec<Option<f64>>)| {
        let _ = write!(out, "{t}");
        for c in cells {
            out.push(',');
            if let Some(y) = c.filter(|y| y.is_finite()) {
                let _ = write!(out, "{y}");
            }
        }
        out.push('\n');
    };
    for (t, c, y) in samples {
        let fits = matches!(&row, Some((rt, cells)) if *rt == t && cells[c].is_none());
        if !fits {
            if let Some(r) = row.take() {
                flush(&mut out, r);
            }
            row = Some((t, vec![None; columns.len()]));
        }
        if let Some((_, cells)) = row.as_mut() {
            cells[c] = Some(y);
        }
    }
    if let Some(r) = row {
        flush(&mut out, r);
    }
    out
}

/// Draws `lines` (and horizontal `marks` with labels) over simulated time into the PNG `path`
/// (900 × 320, the legend under it) and writes the drawn values beside it (`path` with extension `csv`: `t`, then
/// one column per legend entry). With `y_floor` the y axis starts there and values below it are
/// drawn at it (non-negative quantities: `Some(0.0)`); without, the axis spans the data and the
/// marks. Lines without data get no legend entry; non-finite values are gaps.
pub fn plot_lines(
    path: &Path,
    title: &str,
    y_label: &str,
    lines: &[Line<'_>],
    marks: &[(f64, &str)],
    y_floor: Option<f64>,
) -> Result<()> {
    draw(path, title, y_label, lines, marks, YAxis::Linear { floor: y_floor }, None).map(|_| ())
}

/// One plot of a trial: what was drawn, or why nothing was.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialPlot {
    /// Title.
    pub title: String,
    /// The PNG's file name; `None`: not drawn, no series had data.
    pub png: Option<String>,
    /// The CSV's file name beside it (with the PNG).
    pub csv: Option<String>,
    /// Legend entries, each with data in the CSV.
    pub legend: Vec<String>,
    /// What had no data (`no /lwr/joint_velocity_command in this run`).
    pub notes: Vec<String>,
    /// Topics whose absence those notes report.
    pub missing_topics: Vec<&'static str>,
}

/// A series of a trial plot, and what its absence means: (line, note, the topic missing then;
/// `None` when the topic was there and the series is just empty, e.g. never stopped).
type Spec<'a> = (Line<'a>, String, Option<&'static str>);

/// What a trial plot is called: its file stem, title and y-axis label.
struct Names<'a> {
    file: &'a str,
    title: &'a str,
    y_label: &'a str,
}

/// Draws one trial plot over `span` (s) unless none of `specs` has data.
fn trial_plot(
    dir: &Path,
    span: (f64, f64),
    Names { file, title, y_label }: Names<'_>,
    specs: Vec<Spec<'_>>,
    marks: &[(f64, &str)],
    axis: YAxis<'_>,
) -> Result<TrialPlot> {
    let mut plot = TrialPlot { title: title.to_owned(), png: None, csv: None, legend: Vec::new(), notes: Vec::new(), missing_topics: Vec::new() };
    for (line, note, topic) in &specs {
        if !line.has_data() {
            if !plot.notes.contains(note) {
                plot.notes.push(note.clone());
            }
            if let Some(topic) = topic
                && !plot.missing_topics.contains(topic)
            {
                plot.missing_topics.push(topic);
            }
        }
    }
    if !specs.iter().any(|s| s.0.has_data()) {
        return Ok(plot);
    }
    let lines: Vec<Line<'_>> = specs.into_iter().map(|s| s.0).collect();
    let png = format!("{file}.png");
    plot.legend = draw(&dir.join(&png), title, y_label, &lines, marks, axis, Some(span))?;
    plot.csv = Some(format!("{file}.csv"));
    plot.png = Some(png);
    Ok(plot)
}

/// Step function points of a piecewise-constant signal (a non-finite value: a gap).
fn steps(points: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    for (t, y) in points {
        if let Some(&(_, last)) = out.last()
            && last.is_finite()
            && last != y
        {
            out.push((t, last));
        }
        out.push((t, y));
    }
    out
}

/// Rows of the human observer plot: `HumanState.mode` by the message's numbering, the flags,
/// and the gestures (the last row only when there were any).
const STATE_ROWS: [&str; 5] = ["0 MODE_FAR", "1 MODE_INTERACTION", "stopped: true", "present: false", "gesture"];

/// A flag of `/human/state` as a bar at `row` while it holds (a gap otherwise).
fn flag_bar(states: &[(f64, ObservedState)], row: f64, on: impl Fn(&ObservedState) -> bool) -> Vec<(f64, f64)> {
    steps(states.iter().map(|(t, s)| (*t, if on(s) { row } else { f64::NAN })))
}

/// The PNGs (and CSVs) of one trial, named `<stem>-<plot>.png` in `dir`.
pub fn plot_trial(dir: &Path, stem: &str, s: &Series) -> Result<Vec<TrialPlot>> {
    let blue = RGBColor(31, 119, 180);
    let orange = RGBColor(255, 127, 14);
    let green = RGBColor(44, 160, 44);
    let red = RGBColor(214, 39, 40);
    let grey = RGBColor(127, 127, 127);
    let file = |name: &str| format!("{stem}-{name}");
    let no = |topic: &str| format!("no {topic} in this trial's data");
    let mut plots = Vec::new();
    // One time axis for every plot of the trial, so that they line up.
    let times = [&s.distance, &s.measured_distance, &s.processing_ms, &s.tool_speed, &s.alpha, &s.commanded_qdot, &s.executed_qdot]
        .into_iter()
        .flat_map(|v| v.iter().map(|p| p.0))
        .chain(s.human_state.iter().map(|p| p.0))
        .chain(s.gestures.iter().map(|p| p.0))
        .filter(|t| t.is_finite());
    let span = times.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| (a.min(t), b.max(t)));

    // Up close is what matters; farther values are drawn at the cap (the CSV has them so).
    const CAP_M: f64 = 1.0;
    let cap = |p: &[(f64, f64)]| p.iter().map(|&(t, d)| (t, d.min(CAP_M))).collect::<Vec<_>>();
    let measured = if s.backend == "spheres" {
        "Flacco spheres: nearest obstacle of any kind (/fded/distances)"
    } else {
        "fDED: nearest obstacle in the depth image, any kind (/fded/distances)"
    };
    let mark = format!("{:.1} cm: the thesis's smallest robot–person distance with fDED", THESIS_MIN_DISTANCE_M * 100.0);
    plots.push(trial_plot(
        dir,
        span,
        Names {
            file: &file("distance"),
            title: "Robot–person distance (true) and the distance node's nearest obstacle; above 1 m drawn at 1 m",
            y_label: "distance (m)",
        },
        vec![
            (
                Line { name: "robot–person, true (link hulls vs body capsules; 0 = contact)", points: cap(&s.distance), color: blue },
                "no true robot–person distance in this trial's data (nobody on /human/skeleton while /joint_states was known)".into(),
                Some("/human/skeleton"),
            ),
            (
                Line { name: measured, points: cap(&s.measured_distance), color: orange },
                no("valid distance on /fded/distances"),
                Some("/fded/distances"),
            ),
        ],
        &[(THESIS_MIN_DISTANCE_M, mark.as_str())],
        YAxis::Linear { floor: Some(0.0) },
    )?);

    let peak = s.fastest_near_person(INTERACTION_AREA_M);
    plots.push(trial_plot(
        dir,
        span,
        Names { file: &file("speed"), title: "Tool speed and the speed α_h allowed", y_label: "m/s" },
        vec![
            (Line { name: "tool speed (/lwr/world, over ≥ 50 ms)", points: s.tool_speed.clone(), color: blue }, no("/lwr/world"), Some("/lwr/world")),
            (
                Line { name: "α_h allowed (/human/state speed_scale)", points: steps(s.alpha.iter().copied()), color: orange },
                no("/human/state"),
                Some("/human/state"),
            ),
            (
                Line { name: "fastest while the person was within 0.8 m", points: peak.iter().map(|p| (p.t_s, p.speed_m_s)).collect(), color: red },
                "the person never came within 0.8 m while the tool moved".into(),
                None,
            ),
        ],
        &[],
        YAxis::Linear { floor: Some(0.0) },
    )?);

    // The message's fields: mode while someone is tracked, the two flags as bars, and one
    // series per gesture label: a spike at each recognition.
    let mode = steps(s.human_state.iter().map(|(t, h)| (*t, if h.present { f64::from(h.mode) } else { f64::NAN })));
    let state = |note: &str| if s.human_state.is_empty() { (no("/human/state"), Some("/human/state")) } else { (note.to_owned(), None) };
    let (n0, t0) = state("nobody was tracked in this trial");
    let (n1, t1) = state("never stopped in this trial");
    let (n2, t2) = state("someone was tracked all along");
    let mut specs: Vec<Spec<'_>> = vec![
        (Line { name: "mode (while present: true)", points: mode, color: blue }, n0, t0),
        (Line { name: "stopped: true (a stop gesture or word)", points: flag_bar(&s.human_state, 2.0, |h| h.stopped), color: red }, n1, t1),
        (Line { name: "present: false (nobody tracked)", points: flag_bar(&s.human_state, 3.0, |h| !h.present), color: grey }, n2, t2),
    ];
    let mut labels: Vec<&str> = Vec::new();
    for g in &s.gestures {
        if !labels.contains(&g.1.as_str()) {
            labels.push(&g.1);
        }
    }
    let names: Vec<String> = labels.iter().map(|l| format!("gesture: {l} (/human/gesture)")).collect();
    let palette = [green, RGBColor(148, 103, 189), orange, RGBColor(140, 86, 75)];
    for (k, label) in labels.iter().enumerate() {
        let points = s.gestures.iter().filter(|g| g.1 == *label).flat_map(|g| [(g.0 - 0.05, 3.8), (g.0, 4.2), (g.0 + 0.05, 3.8), (g.0 + 0.05, f64::NAN)]).collect();
        specs.push((Line { name: &names[k], points, color: palette[k % palette.len()] }, String::new(), None));
    }
    let observer_title = if labels.is_empty() {
        "Human observer: /human/state mode (HumanState.msg numbering) and flags"
    } else {
        "Human observer: /human/state mode (HumanState.msg numbering) and flags; /human/gesture"
    };
    let mut observer = trial_plot(
        dir,
        span,
        Names { file: &file("mode"), title: observer_title, y_label: "" },
        specs,
        &[],
        YAxis::Rows(if labels.is_empty() { &STATE_ROWS[..4] } else { &STATE_ROWS }),
    )?;
    if labels.is_empty() {
        observer.notes.push(no("/human/gesture"));
        observer.missing_topics.push("/human/gesture");
    }
    plots.push(observer);

    let backend = if s.backend.is_empty() { "distance node".to_owned() } else { format!("backend {}", s.backend) };
    plots.push(trial_plot(
        dir,
        span,
        Names { file: &file("processing"), title: "Distance node processing time per depth frame", y_label: "ms" },
        vec![(
            Line { name: &format!("{backend} (/fded/distances processing_time)"), points: s.processing_ms.clone(), color: blue },
            no("/fded/distances"),
            Some("/fded/distances"),
        )],
        &[],
        YAxis::Linear { floor: Some(0.0) },
    )?);

    plots.push(trial_plot(
        dir,
        span,
        Names { file: &file("qdot"), title: "Joint velocity norm: commanded vs executed", y_label: "rad/s" },
        vec![
            (
                Line { name: "commanded (/lwr/joint_velocity_command)", points: s.commanded_qdot.clone(), color: orange },
                no("/lwr/joint_velocity_command"),
                Some("/lwr/joint_velocity_command"),
            ),
            (
                Line { name: "executed (/joint_states velocity)", points: s.executed_qdot.clone(), color: blue },
                no("joint velocity on /joint_states"),
                Some("/joint_states"),
            ),
        ],
        &[],
        YAxis::Linear { floor: Some(0.0) },
    )?);
    Ok(plots)
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A JSON array of strings (for the `data-legend` attribute).
fn json_strings(v: &[String]) -> String {
    let items: Vec<String> = v
        .iter()
        .map(|s| {
            let mut o = String::from("\"");
            for c in s.chars() {
                match c {
                    '"' => o.push_str("\\\""),
                    '\\' => o.push_str("\\\\"),
                    c if (c as u32) < 0x20 => {
                        let _ = write!(o, "\\u{:04x}", c as u32);
                    }
                    c => o.push(c),
                }
            }
            o.push('"');
            o
        })
        .collect();
    format!("[{}]", items.join(","))
}

/// Every table shrinks to the window: cells wrap (long words too), the headers are short.
const STYLE: &str = "body{font-family:sans-serif;margin:2em;max-width:1400px}\
table{border-collapse:collapse;width:100%;font-size:14px;margin:0.5em 0}\
td,th{border:1px solid #999;padding:3px 6px;overflow-wrap:break-word;vertical-align:top;text-align:left}\
.long{overflow-wrap:anywhere}\
th{background:#eee}\
table.meta{width:auto}table.meta th{font-weight:normal;background:none;color:#555;white-space:nowrap}\
caption{text-align:left;font-weight:bold;padding:4px 0}\
figure{margin:1em 0}img{display:block;max-width:100%;height:auto}\
figcaption{font-size:13px;color:#444}.note{color:#a40}.notice{background:#fff4e0;border:1px solid #e0b060;padding:6px}";

/// Sets `data-images-loaded="N/M"` and `data-summary-fits="yes|no"` (with the widths) on
/// <body> after loading: read by the cross-check's headless Chromium check
/// (tests/crosscheck/check_report.sh); harmless elsewhere.
const LOAD_SCRIPT: &str = "<script>window.addEventListener('load',function(){var i=document.images,n=0;\
for(var k=0;k<i.length;k++){if(i[k].complete&&i[k].naturalWidth>0)n++;}\
var b=document.body,d=document.documentElement;b.setAttribute('data-images-loaded',n+'/'+i.length);\
var t=document.getElementById('summary');if(t){var r=t.getBoundingClientRect();\
var fits=t.scrollWidth<=t.clientWidth+1&&r.right<=d.clientWidth&&d.scrollWidth<=d.clientWidth;\
b.setAttribute('data-summary-fits',fits?'yes':'no');\
b.setAttribute('data-summary-width',Math.ceil(Math.max(t.scrollWidth,r.right))+'/'+d.clientWidth);}});</script>\n";

/// A table of text cells; with `link_first`, row i's first cell links to `#trial{i}`. Cells
/// with a long unbroken word (a path) may break anywhere; the rest wrap between words only.
fn table_html(html: &mut String, id: Option<&str>, caption: &str, header: &[String], rows: &[Vec<String>], link_first: bool) {
    let id = id.map(|i| format!(" id=\"{i}\"")).unwrap_or_default();
    let class = |c: &str| if c.split_whitespace().any(|w| w.chars().count() > 24) { " class=\"long\"" } else { "" };
    let _ = write!(html, "<table{id}><caption>{}</caption>\n<tr>", escape(caption));
    for h in header {
        let _ = write!(html, "<th{}>{}</th>", class(h), escape(h));
    }
    html.push_str("</tr>\n");
    for (i, r) in rows.iter().enumerate() {
        html.push_str("<tr>");
        for (k, c) in r.iter().enumerate() {
            if link_first && k == 0 {
                let _ = write!(html, "<td{}><a href=\"#trial{i}\">{}</a></td>", class(c), escape(c));
            } else {
                let _ = write!(html, "<td{}>{}</td>", class(c), escape(c));
            }
        }
        html.push_str("</tr>\n");
    }
    html.push_str("</table>\n");
}

/// Writes `dir/index.html` and every trial's PNGs and CSVs: the head's metadata and title, the
/// summary (one row per trial), the head's tables, then per trial its plots, each with its CSV
/// linked under it and a note for every series without data; a plot with no data is not drawn
/// and the trial says which topics were missing. `head`: a [`ReportHead`], or just a title
/// (then [`Metadata::of_this_run`]).
pub fn write_report(dir: &Path, head: impl Into<ReportHead>, trials: &[ReportTrial]) -> Result<()> {
    let head: ReportHead = head.into();
    std::fs::create_dir_all(dir).map_err(|e| report_err(dir, e))?;
    let mut html = String::new();
    let t = escape(&head.title);
    let _ = write!(
        html,
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{t}</title>\n<style>{STYLE}</style></head><body>\n<h1>{t}</h1>\n"
    );
    if !head.meta.entries.is_empty() {
        html.push_str("<table class=\"meta\" id=\"metadata\">\n");
        for (k, v) in &head.meta.entries {
            let long = if v.split_whitespace().any(|w| w.chars().count() > 24) { " class=\"long\"" } else { "" };
            let _ = writeln!(html, "<tr><th>{}</th><td{long}>{}</td></tr>", escape(k), escape(v));
        }
        html.push_str("</table>\n");
    }
    if let Some(first) = trials.first() {
        let header: Vec<String> = std::iter::once("trial".to_owned()).chain(first.row.iter().map(|(k, _)| k.clone())).collect();
        let rows: Vec<Vec<String>> = trials
            .iter()
            .map(|tr| std::iter::once(tr.title.clone()).chain(tr.row.iter().map(|(_, v)| v.clone())).collect())
            .collect();
        html.push_str("<h2>Summary</h2>\n");
        table_html(&mut html, Some("summary"), "One row per trial; times in simulated s.", &header, &rows, true);
        if first.row.iter().any(|(k, _)| k == NEAR_PERSON_SPEED) {
            let _ = writeln!(
                html,
                "<p><small>{}: the largest tool speed (from /lwr/world, over ≥ 50 ms) while the true robot–person distance \
                 was below {INTERACTION_AREA_M} m (human_observer's interaction_enter_m); {}: the speed the newest \
                 /human/state allowed at that moment; {}: the true robot–person distance then. \"-\": the person never came \
                 that close while the tool moved.</small></p>",
                escape(NEAR_PERSON_SPEED),
                escape(NEAR_PERSON_ALLOWED),
                escape(NEAR_PERSON_DISTANCE)
            );
        }
    }
    for tb in &head.tables {
        table_html(&mut html, None, &tb.caption, &tb.header, &tb.rows, false);
    }
    for (i, tr) in trials.iter().enumerate() {
        let plots = plot_trial(dir, &format!("trial{i}"), &tr.series)?;
        let _ = writeln!(html, "<h2 id=\"trial{i}\">{}</h2>", escape(&tr.title));
        let mut missing: Vec<&str> = Vec::new();
        for p in &plots {
            for m in &p.missing_topics {
                if !missing.contains(m) {
                    missing.push(m);
                }
            }
        }
        if !missing.is_empty() {
            let _ = writeln!(
                html,
                "<p class=\"notice\">Topics without data in this trial: {}.</p>",
                escape(&missing.join(", "))
            );
        }
        for p in &plots {
            let notes: String = p.notes.iter().map(|n| format!("<br><span class=\"note\">{}</span>", escape(n))).collect();
            match (&p.png, &p.csv) {
                (Some(png), Some(csv)) => {
                    let _ = writeln!(
                        html,
                        "<figure><img src=\"{png}\" alt=\"{}\" data-csv=\"{csv}\" data-legend=\"{}\">\
                         <figcaption>data: <a href=\"{csv}\">{csv}</a>{notes}</figcaption></figure>",
                        escape(&p.title),
                        escape(&json_strings(&p.legend))
                    );
                }
                _ => {
                    let _ = writeln!(
                        html,
                        "<p class=\"notice\">Not drawn: {} (no data).{notes}</p>",
                        escape(&p.title)
                    );
                }
            }
        }
    }
    html.push_str(LOAD_SCRIPT);
    html.push_str("</body></html>\n");
    let index = dir.join("index.html");
    cowork_store::write_atomic(&index, html.as_bytes()).map_err(|e| report_err(&index, e))
}

/// `s` quoted for a POSIX shell when it needs to be.
fn shell_word(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c)) {
        s.to_owned()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// The commit: `COWORK_GIT_COMMIT` at build time, else `git rev-parse HEAD` of the working
/// directory now (marked when the tracked files differ from it), else "unknown".
fn git_commit() -> String {
    if let Some(c) = option_env!("COWORK_GIT_COMMIT").filter(|c| !c.is_empty()) {
        return format!("{c} (at build time)");
    }
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .stderr(std::process::Stdio::null())
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
    };
    match git(&["rev-parse", "--short=12", "HEAD"]).filter(|c| !c.is_empty()) {
        Some(c) => {
            let dirty = git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
            let note = if dirty { ", with uncommitted changes" } else { "" };
            format!("{c} (working tree at report time{note})")
        }
        None => "unknown".into(),
    }
}

/// `time` as `YYYY-MM-DD hh:mm:ss UTC`.
fn utc(time: std::time::SystemTime) -> String {
    let secs = time.duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    // Days to the civil date (H. Hinnant's algorithm, proleptic Gregorian).
    let z = (secs / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    let s = secs % 86_400;
    format!("{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC", s / 3600, s % 3600 / 60, s % 60)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, UNIX_EPOCH};

    fn series_with_person() -> Series {
        let mut s = Series::default();
        for i in 0..200 {
            let t = i as f64 * 0.05;
            s.distance.push((t, 0.5 - 0.06 * t));
            s.measured_distance.push((t, 0.5 - 0.04 * t + 0.01));
            s.tool_speed.push((t, if (4.0..4.2).contains(&t) { 0.538 } else { 0.05 }));
            s.alpha.push((t, if t < 2.0 { 0.3 } else { 0.1 }));
            s.executed_qdot.push((t, 0.2));
            s.processing_ms.push((t, 1.9));
        }
        s.backend = "cpu".into();
        s
    }

    fn legend(dir: &Path, png: &str) -> Vec<String> {
        let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
        let at = html.find(&format!("src=\"{png}\"")).unwrap_or_else(|| panic!("{png} not in {html}"));
        let rest = &html[at..];
        let start = rest.find("data-legend=\"").unwrap() + "data-legend=\"".len();
        let end = start + rest[start..].find('"').unwrap();
        rest[start..end].replace("&quot;", "\"").replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">")
            .trim_matches(|c| c == '[' || c == ']')
            .split("\",\"")
            .map(|s| s.trim_matches('"').to_owned())
            .filter(|s| !s.is_empty())
            .collect()
    }

    /// The columns of a CSV that have at least one number.
    fn columns_with_data(path: &Path) -> Vec<String> {
        let text = std::fs::read_to_string(path).unwrap();
        let mut lines = text.lines();
        let header: Vec<String> = split_csv(lines.next().unwrap());
        let mut has = vec![false; header.len()];
        for l in lines {
            for (k, c) in split_csv(l).iter().enumerate() {
                if c.parse::<f64>().is_ok_and(f64::is_finite) {
                    has[k] = true;
                }
            }
        }
        header.into_iter().zip(has).filter(|(_, h)| *h).map(|(n, _)| n).collect()
    }

    fn split_csv(line: &str) -> Vec<String> {
        let (mut out, mut cell, mut quoted) = (Vec::new(), String::new(), false);
        let mut chars = line.chars().peekable();
        while let Some(c) = chars.next() {
            match c {
                '"' if quoted && chars.peek() == Some(&'"') => {
                    cell.push('"');
                    chars.next();
                }
                '"' => quoted = !quoted,
                ',' if !quoted => out.push(std::mem::take(&mut cell)),
                c => cell.push(c),
            }
        }
        out.push(cell);
        out
    }

    #[test]
    fn no_legend_entry_without_data_and_a_note_instead() {
        let s = series_with_person(); // no /lwr/joint_velocity_command, no /human/state modes
        let dir = tempfile::tempdir().unwrap();
        write_report(dir.path(), "t", &[ReportTrial { title: "t".into(), row: vec![], series: s }]).unwrap();
        let qdot = legend(dir.path(), "trial0-qdot.png");
        assert_eq!(qdot, ["executed (/joint_states velocity)"], "{qdot:?}");
        let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
        assert!(html.contains("no /lwr/joint_velocity_command in this trial's data"), "{html}");
        // Every legend entry of every plot has a column with numbers in its CSV.
        for png in ["trial0-distance.png", "trial0-speed.png", "trial0-processing.png", "trial0-qdot.png"] {
            let with_data = columns_with_data(&dir.path().join(png.replace(".png", ".csv")));
            for name in legend(dir.path(), png) {
                assert!(with_data.contains(&name), "{png}: legend `{name}` has no data ({with_data:?})");
            }
        }
        // Every file renamed into place whole: no temporary left.
        let left: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(cowork_store::TEMP_PREFIX))
            .collect();
        assert!(left.is_empty(), "{left:?}");
    }

    #[test]
    fn non_negative_quantities_stay_at_or_above_zero() {
        let lines = [Line { name: "d", points: vec![(0.0, 0.0), (1.0, -0.02), (2.0, 0.3)], color: RGBColor(0, 0, 0) }];
        let (y0, y1) = y_range(&lines, &[], YAxis::Linear { floor: Some(0.0) });
        assert_eq!(y0, 0.0, "the axis starts at 0, no padding below");
        assert!(y1 > 0.3, "{y1}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.png");
        plot_lines(&path, "d", "m", &lines, &[], Some(0.0)).unwrap();
        let csv = std::fs::read_to_string(path.with_extension("csv")).unwrap();
        let drawn: Vec<f64> = csv.lines().skip(1).map(|l| l.split(',').nth(1).unwrap().parse().unwrap()).collect();
        assert_eq!(drawn, [0.0, 0.0, 0.3], "{csv}");
        // Without a floor the axis follows the data (a signed quantity).
        let (y0, _) = y_range(&lines, &[], YAxis::Linear { floor: None });
        assert!(y0 < -0.02);
    }

    #[test]
    fn a_plot_without_any_data_is_not_drawn_and_the_page_says_so() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = Series::default();
        s.tool_speed.push((0.0, 0.1));
        s.tool_speed.push((1.0, 0.2));
        write_report(dir.path(), "bag", &[ReportTrial { title: "bag".into(), row: vec![], series: s }]).unwrap();
        let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
        for name in ["distance", "mode", "processing", "qdot"] {
            assert!(!dir.path().join(format!("trial0-{name}.png")).exists(), "{name} drawn without data");
            assert!(!html.contains(&format!("trial0-{name}.png")), "{name} linked");
        }
        assert!(dir.path().join("trial0-speed.png").exists() && dir.path().join("trial0-speed.csv").exists());
        assert!(html.contains("Not drawn: Robot–person distance"), "{html}");
        assert!(
            html.contains("Topics without data in this trial: /human/skeleton, /fded/distances, /human/state, /human/gesture, /lwr/joint_velocity_command, /joint_states."),
            "{html}"
        );
    }

    #[test]
    fn human_state_rows_use_the_message_numbering() {
        let mut s = Series::default();
        let st = |mode, present, stopped| ObservedState { mode, present, stopped };
        s.human_state = vec![(0.0, st(0, false, false)), (1.0, st(0, true, false)), (2.0, st(1, true, false)), (3.0, st(1, true, true))];
        let dir = tempfile::tempdir().unwrap();
        let plots = plot_trial(dir.path(), "t", &s).unwrap();
        let mode = plots.iter().find(|p| p.png.as_deref() == Some("t-mode.png")).unwrap();
        assert_eq!(mode.legend, ["mode (while present: true)", "stopped: true (a stop gesture or word)", "present: false (nobody tracked)"]);
        let csv = std::fs::read_to_string(dir.path().join("t-mode.csv")).unwrap();
        // Far (0) from 1 s, interaction (1) from 2 s; nobody tracked from 0 s to 1 s (row 3).
        assert!(csv.contains("\n1,0,,3\n") && csv.contains("\n2,1,,\n") && csv.contains("\n3,1,2,\n"), "{csv}");
        assert_eq!(STATE_ROWS[usize::from(cowork_msgs::msg::HumanState::MODE_FAR)], "0 MODE_FAR");
        assert_eq!(STATE_ROWS[usize::from(cowork_msgs::msg::HumanState::MODE_INTERACTION)], "1 MODE_INTERACTION");
    }

    #[test]
    fn the_fastest_tool_near_the_person_is_in_the_summary_columns() {
        let s = series_with_person();
        let cols = near_person_columns(&s);
        assert_eq!(cols[0], (NEAR_PERSON_SPEED.to_owned(), "0.538".to_owned()));
        assert_eq!(cols[1].1, "0.100");
        // At 4.0 s the person was 0.5 − 0.24 = 0.26 m away.
        assert_eq!(cols[2].1, "0.260");
        assert!(near_person_columns(&Series::default()).iter().all(|c| c.1 == "-"));
    }

    #[test]
    fn summary_metadata_and_tables_are_on_the_page() {
        let dir = tempfile::tempdir().unwrap();
        let head = ReportHead {
            title: "coffee".into(),
            meta: Metadata::default().with("seed", "1").with("rate", "0.5"),
            tables: vec![Table { caption: "Thesis Table 5.5".into(), header: vec!["subtask".into(), "thesis".into()], rows: vec![vec!["add(water)".into(), "71.1".into()]] }],
        };
        let row = vec![("reason".to_owned(), "x".repeat(400))];
        write_report(dir.path(), head, &[ReportTrial { title: "t".into(), row, series: series_with_person() }]).unwrap();
        let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
        assert!(html.contains("<th>seed</th><td>1</td>") && html.contains("Thesis Table 5.5") && html.contains("<td>71.1</td>"));
        assert!(html.contains("id=\"summary\"") && html.contains("overflow-wrap:break-word") && html.contains("data-summary-fits"));
    }

    #[test]
    fn csv_rows_merge_equal_times_and_keep_steps() {
        let csv = csv_table(&[("a,b", vec![(0.0, 1.0), (1.0, 1.0), (1.0, 2.0)]), ("c", vec![(1.0, 5.0), (2.0, f64::NAN)])]);
        assert_eq!(csv, "t,\"a,b\",c\n0,1,\n1,1,\n1,2,5\n2,,\n");
    }

    #[test]
    fn dates_are_utc() {
        let at = |s: u64| utc(UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(at(951_782_400), "2000-02-29 00:00:00 UTC");
        assert_eq!(at(1_796_673_600), "2026-12-07 20:00:00 UTC");
        assert_eq!(at(4_107_542_399), "2100-02-28 23:59:59 UTC");
    }
}
