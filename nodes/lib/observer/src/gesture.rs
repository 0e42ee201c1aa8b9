//! Gesture recognition (thesis Sec. 3.2.1, 5.1.3): the descriptor of the last 50 frames
//! ([`crate::features`]) against labelled templates with DTW ([`cowork_motion::dtw`], local cost
//! the squared Euclidean distance, Sakoe–Chiba band), k-nearest-neighbour vote and a rejection
//! threshold, so that idle standing, walking and reaching are not reported.
//!
//! Templates and the threshold are learned from labelled skeleton streams ([`Learner`]): for
//! every labelled performance, the windows ending at `end − o` for each `o` of
//! `template_offsets_s` become templates; windows that overlap no label (idle, walking,
//! reaching in the training data) are negatives. The threshold maximises, on the training
//! data, `(positive windows recognised correctly by the templates of the *other*
//! performances) − false_positive_weight × (negative windows accepted)`.
//!
//! A report needs `confirm` consecutive accepted evaluations with the same label; after one,
//! the person's recogniser is latched until an evaluation is rejected at least
//! `refractory_s` after the report (one report per performance).

use std::collections::BTreeMap;
use std::path::Path;

use cowork_motion::dtw::dtw_distance;
use serde::{Deserialize, Serialize};

use crate::error::{ObserverError, Result, check};
use crate::features::{FEATURE_DIM, FeatureConfig, Sample, Window, describe};

/// The `format` of model files this version reads and writes.
pub const MODEL_FORMAT: &str = "cowork-gestures/1";

/// How windows are classified and reports debounced.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecognitionConfig {
    /// Neighbours that vote.
    pub k: usize,
    /// Sakoe–Chiba band of the DTW, frames.
    pub band: usize,
    /// Classify every `stride`-th grid frame (1: every 30 Hz frame).
    pub stride: usize,
    /// Consecutive accepted evaluations with the same label before a report.
    pub confirm: usize,
    /// After a report, at least this long before the next one from the same person, s.
    pub refractory_s: f64,
}

impl Default for RecognitionConfig {
    fn default() -> Self {
        Self { k: 3, band: 10, stride: 2, confirm: 2, refractory_s: 1.0 }
    }
}

impl RecognitionConfig {
    /// Rejects out-of-range values.
    pub fn validate(&self, place: &str) -> Result<()> {
        check(&format!("{place}k"), self.k as f64, 1.0, 100.0, "must be 1 to 100")?;
        check(&format!("{place}band"), self.band as f64, 1.0, 1000.0, "must be 1 to 1000 frames")?;
        check(&format!("{place}stride"), self.stride as f64, 1.0, 100.0, "must be 1 to 100")?;
        check(&format!("{place}confirm"), self.confirm as f64, 1.0, 100.0, "must be 1 to 100")?;
        check(&format!("{place}refractory_s"), self.refractory_s, 0.0, 60.0, "must be in [0, 60] s")
    }
}

/// A labelled template window.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Template {
    /// Gesture label.
    pub label: String,
    /// Index of the labelled performance it was cut from.
    pub instance: usize,
    /// `window × FEATURE_DIM` values, row-major.
    pub descriptor: Vec<f64>,
}

/// What learning measured on its training data.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainingReport {
    /// Where the data came from (bag paths, set by the caller).
    pub sources: Vec<String>,
    /// Labelled performances per label.
    pub instances: BTreeMap<String, usize>,
    /// Labelled performances without enough frames (skipped).
    pub skipped_instances: usize,
    /// Positive windows (templates).
    pub positive_windows: usize,
    /// Negative windows (no label).
    pub negative_windows: usize,
    /// Positive windows recognised correctly by other performances' templates at the threshold.
    pub positive_accepted: f64,
    /// Fraction of negative windows under the threshold.
    pub negative_accepted: f64,
    /// Smallest DTW distance of a negative window to a template.
    pub negative_min_distance: Option<f64>,
}

/// A learned gesture model (JSON file).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GestureModel {
    /// [`MODEL_FORMAT`].
    pub format: String,
    /// How windows were cut and described (recognition must use the same).
    pub features: FeatureConfig,
    /// Classification and debouncing.
    pub recognition: RecognitionConfig,
    /// Rejection threshold on the nearest template's DTW distance.
    pub threshold: f64,
    /// The labels, sorted.
    pub labels: Vec<String>,
    /// The templates.
    pub templates: Vec<Template>,
    /// What learning measured.
    pub training: TrainingReport,
}

fn bad_model(path: Option<&Path>, field: impl Into<String>, reason: impl Into<String>) -> ObserverError {
    ObserverError::BadModel { path: path.map(Path::to_path_buf), field: field.into(), reason: reason.into() }
}

impl GestureModel {
    /// Checks the model: format, parameters, labels, template sizes and values.
    pub fn validate(&self, path: Option<&Path>) -> Result<()> {
        if self.format != MODEL_FORMAT {
            return Err(bad_model(path, "format", format!("{:?}, expected {MODEL_FORMAT:?}", self.format)));
        }
        self.features.validate("features.").map_err(|e| bad_model(path, "features", e.to_string()))?;
        self.recognition.validate("recognition.").map_err(|e| bad_model(path, "recognition", e.to_string()))?;
        if !(self.threshold.is_finite() && self.threshold > 0.0) {
            return Err(bad_model(path, "threshold", format!("{} must be a positive number", self.threshold)));
        }
        if self.templates.is_empty() {
            return Err(bad_model(path, "templates", "no template"));
        }
        let n = self.features.window * FEATURE_DIM;
        for (i, t) in self.templates.iter().enumerate() {
            if t.descriptor.len() != n {
                return Err(bad_model(path, format!("templates[{i}].descriptor"), format!("{} values, expected {n} (window × {FEATURE_DIM})", t.descriptor.len())));
            }
            if let Some(j) = t.descriptor.iter().position(|v| !v.is_finite()) {
                return Err(bad_model(path, format!("templates[{i}].descriptor[{j}]"), "not finite"));
            }
            if !self.labels.contains(&t.label) {
                return Err(bad_model(path, format!("templates[{i}].label"), format!("{:?} is not in `labels`", t.label)));
            }
        }
        Ok(())
    }

    /// Reads and checks a model file.
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| ObserverError::Io { path: path.to_path_buf(), source })?;
        let model: Self = serde_json::from_str(&text).map_err(|e| bad_model(Some(path), format!("line {} column {}", e.line(), e.column()), e.to_string()))?;
        model.validate(Some(path))?;
        Ok(model)
    }

    /// Writes the model atomically (temporary file, then rename).
    pub fn to_file(&self, path: &Path) -> Result<()> {
        self.validate(None)?;
        let io = |source| ObserverError::Io { path: path.to_path_buf(), source };
        let text = serde_json::to_string(self).map_err(|e| bad_model(None, "", e.to_string()))?;
        // Learned data: temporary file, fsync, rename, directory fsync (never half a model).
        cowork_store::write_atomic(path, text.as_bytes()).map_err(io)
    }
}

/// A recognised gesture.
#[derive(Clone, Debug, PartialEq)]
pub struct Detection {
    /// Label.
    pub label: String,
    /// Confidence in [0, 1]: the share of the `k` votes won times `1 − d / threshold`.
    pub confidence: f64,
    /// DTW distance to the nearest template of the label.
    pub distance: f64,
    /// Stamp of the window's last frame, s.
    pub stamp: f64,
}

/// The nearest templates of a query and the vote.
#[derive(Clone, Debug, PartialEq)]
pub struct Vote {
    /// Winning label.
    pub label: String,
    /// Votes for it among the k nearest.
    pub votes: usize,
    /// Distance of its nearest member.
    pub distance: f64,
    /// Distance of the nearest template of any label.
    pub nearest: f64,
}

/// k-NN over a model's templates.
#[derive(Clone, Debug)]
pub struct Classifier {
    model: GestureModel,
}

impl Classifier {
    /// The classifier of a checked model.
    pub fn new(model: GestureModel) -> Result<Self> {
        model.validate(None)?;
        Ok(Self { model })
    }

    /// The model.
    pub fn model(&self) -> &GestureModel {
        &self.model
    }

    /// Votes among the `k` nearest templates (DTW, band), excluding templates of performance
    /// `exclude`. Ties go to the label with the nearest member. Cost: one banded DTW per
    /// template, O(templates × window × band × FEATURE_DIM).
    pub fn vote(&self, query: &[f64], exclude: Option<usize>) -> Result<Option<Vote>> {
        let band = Some(self.model.recognition.band);
        let mut d: Vec<(f64, usize)> = Vec::with_capacity(self.model.templates.len());
        for (i, t) in self.model.templates.iter().enumerate() {
            if exclude == Some(t.instance) {
                continue;
            }
            d.push((dtw_distance(query, &t.descriptor, FEATURE_DIM, band)?, i));
        }
        Ok(knn_vote(&d, &self.model.templates, self.model.recognition.k))
    }

    /// Classifies a descriptor: `Some` when the vote's winner is under the threshold.
    pub fn classify(&self, query: &[f64], stamp: f64) -> Result<Option<Detection>> {
        let Some(v) = self.vote(query, None)? else { return Ok(None) };
        let t = self.model.threshold;
        if v.distance >= t {
            return Ok(None);
        }
        let k = self.model.recognition.k.min(self.model.templates.len()).max(1);
        let confidence = (v.votes as f64 / k as f64) * (1.0 - v.distance / t).clamp(0.0, 1.0);
        Ok(Some(Detection { label: v.label, confidence, distance: v.distance, stamp }))
    }
}

fn knn_vote(d: &[(f64, usize)], templates: &[Template], k: usize) -> Option<Vote> {
    let mut d = d.to_vec();
    d.sort_by(|a, b| a.0.total_cmp(&b.0));
    let nearest = d.first()?.0;
    let mut votes: Vec<(&str, usize, f64)> = Vec::new();
    for (dist, i) in d.iter().take(k.max(1)) {
        let label = templates[*i].label.as_str();
        match votes.iter_mut().find(|v| v.0 == label) {
            Some(v) => v.1 += 1,
            None => votes.push((label, 1, *dist)),
        }
    }
    let best = votes.iter().max_by(|a, b| a.1.cmp(&b.1).then(b.2.total_cmp(&a.2)))?;
    Some(Vote { label: best.0.to_owned(), votes: best.1, distance: best.2, nearest })
}

/// One person's sliding window and report debouncing.
#[derive(Clone, Debug)]
pub struct GestureTracker {
    window: Window,
    since_eval: usize,
    streak: Option<(String, usize)>,
    latched_at: Option<f64>,
    evaluations: u64,
}

impl GestureTracker {
    /// A tracker cutting windows as `features` says.
    pub fn new(features: FeatureConfig) -> Result<Self> {
        Ok(Self { window: Window::new(features)?, since_eval: 0, streak: None, latched_at: None, evaluations: 0 })
    }

    /// Forgets the window (e.g. the person was lost).
    pub fn reset(&mut self) {
        self.window.clear();
        self.streak = None;
        self.since_eval = 0;
    }

    /// Windows classified so far.
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }

    /// Adds a frame; returns a report when a gesture is recognised.
    pub fn push(&mut self, sample: Sample, classifier: &Classifier) -> Result<Option<Detection>> {
        let added = self.window.push(sample);
        if added == 0 || !self.window.is_full() {
            return Ok(None);
        }
        self.since_eval += added;
        let r = &classifier.model().recognition;
        if self.since_eval < r.stride {
            return Ok(None);
        }
        self.since_eval = 0;
        let (Some(desc), Some(stamp)) = (self.window.descriptor(), self.window.end_stamp()) else { return Ok(None) };
        self.evaluations += 1;
        let hit = classifier.classify(&desc, stamp)?;
        let Some(det) = hit else {
            self.streak = None;
            if self.latched_at.is_some_and(|t| stamp - t >= r.refractory_s) {
                self.latched_at = None;
            }
            return Ok(None);
        };
        let count = match &mut self.streak {
            Some((l, c)) if *l == det.label => {
                *c += 1;
                *c
            }
            _ => {
                self.streak = Some((det.label.clone(), 1));
                1
            }
        };
        if count >= r.confirm && self.latched_at.is_none() {
            self.latched_at = Some(stamp);
            return Ok(Some(det));
        }
        Ok(None)
    }
}

/// One labelled performance: `label` from `start` to `end` (s, the stream's clock), performed
/// by `person_id` (any tracked person when `None`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Label {
    /// Gesture label.
    pub label: String,
    /// Start, s.
    pub start: f64,
    /// End, s.
    pub end: f64,
    /// Performer.
    #[serde(default)]
    pub person_id: Option<u32>,
}

impl Label {
    /// Parses the JSON of a `/human/gesture_label` message (`label`, `start`, `end` in s,
    /// optional `person_id`; other fields ignored).
    pub fn from_json(text: &str) -> Result<Self> {
        #[derive(Deserialize)]
        struct Raw {
            label: String,
            start: f64,
            end: f64,
            #[serde(default)]
            person_id: Option<u32>,
        }
        let r: Raw = serde_json::from_str(text).map_err(|e| ObserverError::Training { reason: format!("gesture label {text:?}: {e}") })?;
        if r.label.trim().is_empty() || !(r.start.is_finite() && r.end.is_finite() && r.end > r.start) {
            return Err(ObserverError::Training { reason: format!("gesture label {text:?}: needs a label and start < end") });
        }
        Ok(Self { label: r.label, start: r.start, end: r.end, person_id: r.person_id })
    }
}

/// How a model is learned.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LearnConfig {
    /// Window description.
    pub features: FeatureConfig,
    /// Classification written into the model.
    pub recognition: RecognitionConfig,
    /// Templates are the windows ending this long before each performance's end, s.
    pub template_offsets_s: Vec<f64>,
    /// A window is negative when it stays this far from every label, s.
    pub negative_margin_s: f64,
    /// Every n-th negative window is used to choose the threshold.
    pub negative_stride: usize,
    /// Cost of one accepted negative window against one recognised positive one.
    pub false_positive_weight: f64,
}

impl Default for LearnConfig {
    fn default() -> Self {
        Self {
            features: FeatureConfig::default(),
            recognition: RecognitionConfig::default(),
            template_offsets_s: vec![0.0, 0.3, 0.6],
            negative_margin_s: 0.3,
            negative_stride: 4,
            false_positive_weight: 3.0,
        }
    }
}

/// Collects grid samples per person; [`Learner::finish`] cuts the windows and learns.
#[derive(Debug)]
pub struct Learner {
    config: LearnConfig,
    windows: BTreeMap<u32, (Window, u64, f64)>,
    /// Contiguous runs of grid samples: (person, samples).
    runs: Vec<(u32, Vec<Sample>)>,
    open: BTreeMap<u32, usize>,
}

impl Learner {
    /// An empty learner.
    pub fn new(config: LearnConfig) -> Result<Self> {
        config.features.validate("features.")?;
        config.recognition.validate("recognition.")?;
        if config.template_offsets_s.is_empty() || config.template_offsets_s.iter().any(|o| !(o.is_finite() && *o >= 0.0)) {
            return Err(ObserverError::InvalidParameter { name: "template_offsets_s".into(), value: f64::NAN, expected: "one or more offsets ≥ 0 s" });
        }
        check("negative_margin_s", config.negative_margin_s, 0.0, 60.0, "must be in [0, 60] s")?;
        check("negative_stride", config.negative_stride as f64, 1.0, 1000.0, "must be 1 to 1000")?;
        check("false_positive_weight", config.false_positive_weight, 0.0, 1e6, "must be ≥ 0")?;
        Ok(Self { config, windows: BTreeMap::new(), runs: Vec::new(), open: BTreeMap::new() })
    }

    /// Adds one frame of `person` (frames of a person must come in stamp order; others are
    /// ignored).
    pub fn push(&mut self, person: u32, sample: Sample) -> Result<()> {
        if !self.windows.contains_key(&person) {
            self.windows.insert(person, (Window::new(self.config.features.clone())?, u64::MAX, f64::NEG_INFINITY));
        }
        let Some((w, generation, last)) = self.windows.get_mut(&person) else { return Ok(()) };
        if sample.stamp <= *last {
            return Ok(());
        }
        *last = sample.stamp;
        let added = w.push(sample);
        if w.generation() != *generation {
            *generation = w.generation();
            self.open.remove(&person);
        }
        if added > 0 {
            let run = match self.open.get(&person) {
                Some(i) => *i,
                None => {
                    self.runs.push((person, Vec::new()));
                    self.open.insert(person, self.runs.len() - 1);
                    self.runs.len() - 1
                }
            };
            self.runs[run].1.extend(w.latest(added).copied());
        }
        Ok(())
    }

    /// Cuts template and negative windows for `labels` and learns the threshold.
    pub fn finish(self, labels: &[Label]) -> Result<GestureModel> {
        let c = &self.config;
        let n = c.features.window;
        let dur = c.features.duration();
        let half = 0.5 * c.features.period();
        let mut templates = Vec::new();
        let mut negatives = Vec::new();
        let mut instances: BTreeMap<String, usize> = BTreeMap::new();
        let mut skipped = 0;
        let mut neg_counter = 0usize;
        let mut found = vec![false; labels.len()];
        for (person, run) in &self.runs {
            if run.len() < n {
                continue;
            }
            for end in (n - 1)..run.len() {
                let t = run[end].stamp;
                let mine = |l: &Label| l.person_id.is_none_or(|p| p == *person);
                let mut near_label = false;
                for (i, l) in labels.iter().enumerate().filter(|(_, l)| mine(l)) {
                    if t - dur < l.end + c.negative_margin_s && t > l.start - c.negative_margin_s {
                        near_label = true;
                    }
                    if c.template_offsets_s.iter().any(|o| ((l.end - o) - t).abs() <= half)
                        && let Some(d) = describe(&run[end + 1 - n..=end], &c.features)
                    {
                        found[i] = true;
                        templates.push(Template { label: l.label.clone(), instance: i, descriptor: d });
                    }
                }
                if !near_label {
                    neg_counter += 1;
                    if neg_counter.is_multiple_of(c.negative_stride)
                        && let Some(d) = describe(&run[end + 1 - n..=end], &c.features)
                    {
                        negatives.push(d);
                    }
                }
            }
        }
        for (i, l) in labels.iter().enumerate() {
            if found[i] {
                *instances.entry(l.label.clone()).or_default() += 1;
            } else {
                skipped += 1;
            }
        }
        if templates.is_empty() {
            return Err(ObserverError::Training { reason: format!("no labelled performance has a full {n}-frame window ({} labels)", labels.len()) });
        }
        let mut names: Vec<String> = instances.keys().cloned().collect();
        names.sort();
        let mut model = GestureModel {
            format: MODEL_FORMAT.into(),
            features: c.features.clone(),
            recognition: c.recognition.clone(),
            threshold: 1.0,
            labels: names,
            templates,
            training: TrainingReport { instances, skipped_instances: skipped, ..Default::default() },
        };
        let classifier = Classifier::new(model.clone())?;
        // Leave-one-performance-out: each template against the other performances' templates.
        let mut pos = Vec::with_capacity(model.templates.len());
        for t in &model.templates {
            if let Some(v) = classifier.vote(&t.descriptor, Some(t.instance))? {
                pos.push((v.distance, v.label == t.label));
            }
        }
        let mut neg = Vec::with_capacity(negatives.len());
        for d in &negatives {
            if let Some(v) = classifier.vote(d, None)? {
                neg.push(v.distance);
            }
        }
        let threshold = choose_threshold(&pos, &neg, c.false_positive_weight);
        model.threshold = threshold;
        let r = &mut model.training;
        r.positive_windows = model.templates.len();
        r.negative_windows = neg.len();
        r.positive_accepted = pos.iter().filter(|(d, ok)| *ok && *d < threshold).count() as f64 / pos.len().max(1) as f64;
        r.negative_accepted = neg.iter().filter(|d| **d < threshold).count() as f64 / neg.len().max(1) as f64;
        r.negative_min_distance = neg.iter().copied().min_by(f64::total_cmp);
        model.validate(None)?;
        Ok(model)
    }
}

/// The threshold maximising `correct positives − w × accepted negatives` over the candidate
/// values (every observed distance), placed half way to the next larger candidate; without
/// negatives, 1.5 × the 95th percentile of the correct positives' distances.
pub fn choose_threshold(pos: &[(f64, bool)], neg: &[f64], w: f64) -> f64 {
    let mut correct: Vec<f64> = pos.iter().filter(|p| p.1).map(|p| p.0).collect();
    correct.sort_by(f64::total_cmp);
    if correct.is_empty() {
        return pos.iter().map(|p| p.0).fold(0.0, f64::max).max(1e-6);
    }
    if neg.is_empty() {
        let i = ((correct.len() - 1) as f64 * 0.95).round() as usize;
        return (1.5 * correct[i]).max(1e-6);
    }
    let mut negs = neg.to_vec();
    negs.sort_by(f64::total_cmp);
    let mut candidates: Vec<f64> = correct.iter().chain(negs.iter()).copied().collect();
    candidates.sort_by(f64::total_cmp);
    candidates.dedup();
    let mut best = (f64::NEG_INFINITY, candidates[0]);
    for (i, c) in candidates.iter().enumerate() {
        // Accept everything ≤ c: threshold just above c.
        let tp = correct.partition_point(|d| d <= c) as f64;
        let fp = negs.partition_point(|d| d <= c) as f64;
        let score = tp - w * fp;
        if score > best.0 {
            let next = candidates.get(i + 1).copied().unwrap_or(c * 1.2);
            best = (score, 0.5 * (c + next));
        }
    }
    best.1.max(1e-6)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn threshold_separates_positives_from_negatives() {
        let pos = [(1.0, true), (2.0, true), (3.0, true), (2.5, false)];
        let neg = [5.0, 6.0, 7.0];
        let t = choose_threshold(&pos, &neg, 3.0);
        assert!(t > 3.0 && t < 5.0, "{t}");
        // An overlapping negative costs more than it gains.
        let neg = [2.9, 6.0];
        let t = choose_threshold(&pos, &neg, 3.0);
        assert!(t > 2.0 && t <= 2.9, "{t}");
        assert!(choose_threshold(&pos, &[], 3.0) > 3.0);
    }

    #[test]
    fn labels_parse_and_bad_ones_fail() {
        let l = Label::from_json(r#"{"label":"come","start":3.5,"end":5.9,"person_id":2,"index":1}"#).expect("label");
        assert_eq!(l, Label { label: "come".into(), start: 3.5, end: 5.9, person_id: Some(2) });
        assert!(Label::from_json(r#"{"label":"come","start":5.0,"end":4.0}"#).is_err());
        assert!(Label::from_json(r#"{"label":"","start":1.0,"end":4.0}"#).is_err());
        assert!(Label::from_json("not json").is_err());
    }
}
