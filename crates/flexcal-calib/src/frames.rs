//! The frames a target or a payload is fixed to: a frame of the robot by
//! name, or [`TCP_FRAME`], the end frame followed by the robot's tool.

use flexcal_kinematics::Model;

use crate::error::CalibError;

/// Whether a frame (measurement frame or target offset) is identified.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum FrameTreatment {
    /// Identified together with the robot (default).
    #[default]
    Identify,
    /// Kept at its given (or nominal) value.
    Fixed,
}

/// The frame name that stands for the TCP: the end frame followed by the
/// robot's tool transform.
pub const TCP_FRAME: &str = "tcp";

/// The index of frame `frame` of `model` and whether it is the TCP (the
/// end frame, the tool after it), for the target `what` of `source`.
///
/// # Errors
/// [`CalibError::BadMeasurement`] naming `what`, the robot and its frames
/// when it has no such frame.
pub(crate) fn resolve_frame(
    model: &Model,
    source: &str,
    what: &str,
    frame: &str,
) -> Result<(usize, bool), CalibError> {
    if frame == TCP_FRAME {
        return Ok((model.end_frame(), true));
    }
    model
        .frame_index(frame)
        .map(|f| (f, false))
        .ok_or_else(|| CalibError::BadMeasurement {
            source_name: source.to_string(),
            line: 0,
            what: format!(
                "{what}: robot `{}` has no frame `{frame}` (frames: {}, or `{TCP_FRAME}`)",
                model.name(),
                model.frame_names().join(", ")
            ),
        })
}
