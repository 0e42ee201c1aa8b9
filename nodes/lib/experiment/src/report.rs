//! The run report: per trial PNG plots (plotters) and one static `index.html` with a summary
//! table, so it opens anywhere without a server.

use std::fmt::Write as _;
use std::path::Path;
use std::sync::OnceLock;

use plotters::prelude::*;
pub use plotters::style::RGBColor;

use crate::error::{Error, Result};
use crate::judge::{Mode, Series, THESIS_MIN_DISTANCE_M};

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

/// A line of (t, y) samples with its legend.
#[derive(Debug, Clone)]
pub struct Line<'a> {
    /// Legend.
    pub name: &'a str,
    /// (time s, value) samples.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: RGBColor,
}

fn range(lines: &[Line<'_>], floor: Option<f64>) -> ((f64, f64), (f64, f64)) {
    let (mut t0, mut t1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for l in lines {
        for &(t, y) in &l.points {
            if t.is_finite() && y.is_finite() {
                t0 = t0.min(t);
                t1 = t1.max(t);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
    }
    if !t0.is_finite() {
        (t0, t1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if let Some(f) = floor {
        y0 = y0.min(f);
    }
    if t1 - t0 < 1e-6 {
        t1 = t0 + 1.0;
    }
    if y1 - y0 < 1e-9 {
        y1 = y0 + 1.0;
    }
    let pad = 0.05 * (y1 - y0);
    ((t0, t1), (y0 - pad, y1 + pad))
}

/// Draws `lines` (and horizontal `marks` with labels) over simulated time into the PNG `path`
/// (900 × 320), the y axis from `y_floor` (or the first mark, or the data) up.
pub fn plot_lines(
    path: &Path,
    title: &str,
    y_label: &str,
    lines: &[Line<'_>],
    marks: &[(f64, &str)],
    y_floor: Option<f64>,
) -> Result<()> {
    ensure_font()?;
    let root = BitMapBackend::new(path, (900, 320)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| report_err(path, e))?;
    let ((t0, t1), (y0, y1)) = range(lines, y_floor.or(marks.first().map(|m| m.0)));
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(t0..t1, y0..y1)
        .map_err(|e| report_err(path, e))?;
    chart
        .configure_mesh()
        .x_desc("simulated time (s)")
        .y_desc(y_label)
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| report_err(path, e))?;
    for l in lines {
        let color = l.color;
        chart
            .draw_series(LineSeries::new(
                l.points.iter().copied().filter(|p| p.1.is_finite()),
                color.stroke_width(2),
            ))
            .map_err(|e| report_err(path, e))?
            .label(l.name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
    }
    for &(y, name) in marks {
        chart
            .draw_series(LineSeries::new([(t0, y), (t1, y)], RED.stroke_width(1)))
            .map_err(|e| report_err(path, e))?
            .label(name)
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(1)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| report_err(path, e))?;
    root.present().map_err(|e| report_err(path, e))?;
    Ok(())
}

fn mode_value(m: Mode) -> f64 {
    match m {
        Mode::Absent => 0.0,
        Mode::Far => 1.0,
        Mode::Interaction => 2.0,
        Mode::Stopped => 3.0,
    }
}

/// Step function points of a piecewise-constant signal.
fn steps(points: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    for (t, y) in points {
        if let Some(&(_, last)) = out.last()
            && last != y
        {
            out.push((t, last));
        }
        out.push((t, y));
    }
    out
}

/// The PNGs of one trial, named `<stem>-<plot>.png` in `dir`; returns the file names.
pub fn plot_trial(dir: &Path, stem: &str, s: &Series) -> Result<Vec<String>> {
    ensure_font()?;
    let blue = RGBColor(31, 119, 180);
    let orange = RGBColor(255, 127, 14);
    let green = RGBColor(44, 160, 44);
    let mut files = Vec::new();
    let mut out = |name: &str| {
        let f = format!("{stem}-{name}.png");
        files.push(f.clone());
        dir.join(f)
    };
    plot_lines(
        &out("distance"),
        "Robot-person minimum distance",
        "distance (m)",
        &[
            Line {
                name: "true (robot hulls vs body capsules)",
                points: s.distance.clone(),
                color: blue,
            },
            Line {
                name: if s.backend == "spheres" {
                    "measured (Flacco spheres)"
                } else {
                    "measured (fDED)"
                },
                points: s
                    .measured_distance
                    .iter()
                    .map(|&(t, d)| (t, d.min(1.5)))
                    .collect(),
                color: orange,
            },
        ],
        &[(THESIS_MIN_DISTANCE_M, "6.7 cm (thesis minimum with fDED)")],
        Some(0.0),
    )?;
    plot_lines(
        &out("speed"),
        "Tool speed and alpha_h",
        "m/s",
        &[
            Line {
                name: "tool speed (/lwr/world)",
                points: s.tool_speed.clone(),
                color: blue,
            },
            Line {
                name: "alpha_h (/human/state)",
                points: steps(s.alpha.iter().copied()),
                color: orange,
            },
        ],
        &[],
        Some(0.0),
    )?;
    // One series per gesture label: a spike (3.4 → 3.8) at each recognition, in its colour.
    let mut labels: Vec<&str> = Vec::new();
    for g in &s.gestures {
        if !labels.contains(&g.1.as_str()) {
            labels.push(&g.1);
        }
    }
    let palette = [green, RGBColor(214, 39, 40), RGBColor(148, 103, 189), orange];
    let names: Vec<String> = labels.iter().map(|l| format!("gesture: {l}")).collect();
    let mut lines = vec![Line {
        name: "mode",
        points: steps(s.mode.iter().map(|&(t, m)| (t, mode_value(m)))),
        color: blue,
    }];
    for (k, label) in labels.iter().enumerate() {
        let points = s
            .gestures
            .iter()
            .filter(|g| g.1 == *label)
            .flat_map(|g| [(g.0 - 0.05, 3.4), (g.0, 3.8), (g.0 + 0.05, 3.4)])
            .collect();
        lines.push(Line {
            name: &names[k],
            points,
            color: palette[k % palette.len()],
        });
    }
    plot_lines(
        &out("mode"),
        "Human observer mode (0 nobody, 1 far, 2 interaction, 3 stopped); gestures: spikes",
        "mode",
        &lines,
        &[],
        Some(0.0),
    )?;
    plot_lines(
        &out("processing"),
        "Distance node processing time per depth frame",
        "ms",
        &[Line {
            name: if s.backend.is_empty() {
                "processing"
            } else {
                &s.backend
            },
            points: s.processing_ms.clone(),
            color: blue,
        }],
        &[],
        Some(0.0),
    )?;
    plot_lines(
        &out("qdot"),
        "Joint velocity norm: commanded vs executed",
        "rad/s",
        &[
            Line {
                name: "commanded (/lwr/joint_velocity_command)",
                points: s.commanded_qdot.clone(),
                color: orange,
            },
            Line {
                name: "executed (/joint_states)",
                points: s.executed_qdot.clone(),
                color: blue,
            },
        ],
        &[],
        Some(0.0),
    )?;
    Ok(files)
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Writes `dir/index.html` and every trial's PNGs.
pub fn write_report(dir: &Path, title: &str, trials: &[ReportTrial]) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| report_err(dir, e))?;
    let mut html = String::new();
    let t = escape(title);
    let _ = write!(
        html,
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{t}</title>\n<style>body{{font-family:sans-serif;margin:2em}}table{{border-collapse:collapse}}td,th{{border:1px solid #999;padding:3px 8px}}img{{display:block;margin:6px 0}}</style></head><body>\n<h1>{t}</h1>\n"
    );
    if let Some(first) = trials.first() {
        html.push_str("<h2>Summary</h2>\n<table><tr><th>trial</th>");
        for (k, _) in &first.row {
            let _ = write!(html, "<th>{}</th>", escape(k));
        }
        html.push_str("</tr>\n");
        for (i, tr) in trials.iter().enumerate() {
            let _ = write!(
                html,
                "<tr><td><a href=\"#trial{i}\">{}</a></td>",
                escape(&tr.title)
            );
            for (_, v) in &tr.row {
                let _ = write!(html, "<td>{}</td>", escape(v));
            }
            html.push_str("</tr>\n");
        }
        html.push_str("</table>\n");
    }
    for (i, tr) in trials.iter().enumerate() {
        let files = plot_trial(dir, &format!("trial{i}"), &tr.series)?;
        let _ = writeln!(html, "<h2 id=\"trial{i}\">{}</h2>", escape(&tr.title));
        for f in files {
            let _ = writeln!(html, "<img src=\"{f}\" alt=\"{f}\">");
        }
    }
    // Marks how many plots the browser could load (read by the cross-check's headless
    // Chromium screenshot check, tests/crosscheck/check_report.sh; harmless elsewhere).
    html.push_str(
        "<script>window.addEventListener('load',function(){var i=document.images,n=0;\
         for(var k=0;k<i.length;k++){if(i[k].complete&&i[k].naturalWidth>0)n++;}\
         document.body.setAttribute('data-images-loaded',n+'/'+i.length);});</script>\n",
    );
    html.push_str("</body></html>\n");
    let index = dir.join("index.html");
    std::fs::write(&index, html).map_err(|e| report_err(&index, e))
}
