//! Reading attribute values from a dicom-rs object, including the functional groups of enhanced
//! (multi-frame) objects.
//!
//! In: an object and a tag. Out: `None` when the attribute is absent or empty, `Err(message)`
//! when it is present but unparsable (the caller adds the file name).

use dicom_core::Tag;
use dicom_dictionary_std::tags;
use dicom_object::InMemDicomObject;

pub(crate) fn string(obj: &InMemDicomObject, tag: Tag) -> Option<String> {
    let e = obj.get(tag)?;
    let s = e.to_str().ok()?;
    let s = s.trim_matches(|c: char| c.is_whitespace() || c == '\0');
    (!s.is_empty()).then(|| s.to_string())
}

/// All values of a multi-valued string attribute (e.g. ImageType), trimmed, upper-cased.
pub(crate) fn strings(obj: &InMemDicomObject, tag: Tag) -> Vec<String> {
    match string(obj, tag) {
        Some(s) => s
            .split('\\')
            .map(|v| v.trim().to_ascii_uppercase())
            .collect(),
        None => Vec::new(),
    }
}

pub(crate) fn floats(
    obj: &InMemDicomObject,
    tag: Tag,
    name: &str,
) -> Result<Option<Vec<f64>>, String> {
    let Some(e) = obj.get(tag) else {
        return Ok(None);
    };
    if e.to_str().map(|s| s.trim().is_empty()).unwrap_or(false) {
        return Ok(None);
    }
    match e.to_multi_float64() {
        Ok(v) if v.is_empty() => Ok(None),
        Ok(v) => Ok(Some(v)),
        Err(err) => Err(format!(
            "{name} is not a list of numbers ({:?}): {err}",
            e.to_str().unwrap_or_default()
        )),
    }
}

pub(crate) fn int(obj: &InMemDicomObject, tag: Tag) -> Option<i64> {
    let e = obj.get(tag)?;
    e.to_int::<i64>().ok()
}

/// The first item of sequence `seq` in `obj`.
fn first_item(obj: &InMemDicomObject, seq: Tag) -> Option<&InMemDicomObject> {
    obj.get(seq)?.items()?.first()
}

/// Where a per-frame attribute is looked up: the frame's item of the Per-Frame Functional Groups,
/// then the Shared Functional Groups, then (classic objects) the top level.
pub(crate) struct FrameGroups<'a> {
    pub top: &'a InMemDicomObject,
    pub per_frame: Option<&'a InMemDicomObject>,
    pub shared: Option<&'a InMemDicomObject>,
}

impl<'a> FrameGroups<'a> {
    pub fn new(top: &'a InMemDicomObject, frame: Option<usize>) -> Self {
        let per_frame = frame.and_then(|k| {
            top.get(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE)?
                .items()?
                .get(k)
        });
        let shared = first_item(top, tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE);
        FrameGroups {
            top,
            per_frame,
            shared,
        }
    }

    /// The object holding `tag` inside macro sequence `seq`, by precedence.
    fn holder(&self, seq: Tag, tag: Tag) -> Option<&'a InMemDicomObject> {
        for g in [self.per_frame, self.shared].into_iter().flatten() {
            if let Some(item) = first_item(g, seq) {
                if item.get(tag).is_some() {
                    return Some(item);
                }
            }
        }
        self.top.get(tag).map(|_| self.top)
    }

    pub fn floats(&self, seq: Tag, tag: Tag, name: &str) -> Result<Option<Vec<f64>>, String> {
        match self.holder(seq, tag) {
            Some(o) => floats(o, tag, name),
            None => Ok(None),
        }
    }

    pub fn int(&self, seq: Tag, tag: Tag) -> Option<i64> {
        self.holder(seq, tag).and_then(|o| int(o, tag))
    }
}
