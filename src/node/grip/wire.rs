//! What `~/grip` puts on the wire: its own service (`srv/Grip.srv`) and the two gripper actions
//! of control_msgs (Jazzy, 5.8.0: `GripperCommand.msg`, `GripperCommand.action`,
//! `ParallelGripperCommand.action`, kept verbatim in `src/msg/jazzy/control_msgs/`), with
//! `sensor_msgs/JointState` (common_interfaces 5.3.6, `src/msg/jazzy/sensor_msgs/`). An action's
//! goal, result and feedback are each a struct of the fields between its `---` lines, as rosidl
//! generates them (`<Name>_Goal`, `_Result`, `_Feedback`); ros2-client wraps them in the
//! goal id and status of `action_msgs`. The tests below hold every struct to its text, field for
//! field.

use crate::msg::{Header, RosType};
use serde::{Deserialize, Serialize};

/// A wire struct, its `(name, ROS type)` list for the tests, and, given `= "pkg/Name"`, its
/// name as a field type.
macro_rules! wire {
    (
        $(#[$meta:meta])* $name:ident $(= $ros:literal)? {
            $( $(#[$fmeta:meta])* $field:ident : $fty:ty ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
        pub(crate) struct $name {
            $( $(#[$fmeta])* pub(crate) $field: $fty, )*
        }

        impl $name {
            /// `(name, ROS type)` of every field, in order.
            #[cfg(test)]
            pub(crate) fn fields() -> Vec<(&'static str, String)> {
                vec![ $( (stringify!($field), <$fty as RosType>::ros_type()) ),* ]
            }
        }

        impl ros2_client::Message for $name {}

        $(impl RosType for $name {
            fn ros_type() -> String {
                $ros.to_string()
            }
        })?
    };
}

wire! {
    /// `srv/Grip.srv`, request.
    GripRequest {
        /// The `candidate_id` of an answer the node gave.
        grasp_id: String,
    }
}

wire! {
    /// `srv/Grip.srv`, response (each field's meaning is in the file).
    GripResponse {
        /// The action server accepted the goal.
        sent: bool,
        /// N, the answer's grip force.
        recommended_force: f64,
        /// N, the effort sent.
        force: f64,
        /// The action the goal went to.
        action: String,
        /// `action_msgs/GoalStatus` of the result, 0 when none came.
        goal_status: i8,
        /// The result's position.
        position: f64,
        /// The result's effort.
        effort: f64,
        /// The result's `stalled`.
        stalled: bool,
        /// The result's `reached_goal`.
        reached_goal: bool,
        /// Why, or what was sent.
        message: String,
    }
}

wire! {
    /// `control_msgs/msg/GripperCommand`.
    GripperCommand = "control_msgs/GripperCommand" {
        /// The position commanded, m (or the controller's unit).
        position: f64,
        /// The most effort the gripper may exert, N.
        max_effort: f64,
    }
}

wire! {
    /// `control_msgs/action/GripperCommand`, goal.
    GripperCommandGoal {
        /// The command.
        command: GripperCommand,
    }
}

wire! {
    /// `control_msgs/action/GripperCommand`, result (the feedback has the same fields).
    GripperCommandResult {
        /// The gap now, m.
        position: f64,
        /// The effort now, N.
        effort: f64,
        /// At max effort and not moving.
        stalled: bool,
        /// At the commanded position.
        reached_goal: bool,
    }
}

/// `control_msgs/action/GripperCommand`, feedback: the result's fields.
pub(crate) type GripperCommandFeedback = GripperCommandResult;

wire! {
    /// `sensor_msgs/msg/JointState`.
    JointState = "sensor_msgs/JointState" {
        /// Stamp and frame.
        header: Header,
        /// The joints' names.
        name: Vec<String>,
        /// Each joint's position (rad or m).
        position: Vec<f64>,
        /// Each joint's velocity (empty: not used).
        velocity: Vec<f64>,
        /// Each joint's effort (N or N m; empty: not used).
        effort: Vec<f64>,
    }
}

wire! {
    /// `control_msgs/action/ParallelGripperCommand`, goal.
    ParallelGripperGoal {
        /// The joints, their positions and their most effort.
        command: JointState,
    }
}

wire! {
    /// `control_msgs/action/ParallelGripperCommand`, result.
    ParallelGripperResult {
        /// The gripper's state.
        state: JointState,
        /// At max effort and not moving.
        stalled: bool,
        /// At the commanded position.
        reached_goal: bool,
    }
}

wire! {
    /// `control_msgs/action/ParallelGripperCommand`, feedback.
    ParallelGripperFeedback {
        /// The gripper's state.
        state: JointState,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `(name, type)` of every field of a `.msg` text (or one part of a `.srv`/`.action`), with
    /// comments, blank lines and constants left out and a relative type qualified by `package`.
    fn parse(text: &str, package: &str) -> Vec<(String, String)> {
        text.lines()
            .map(|l| l.split('#').next().unwrap_or("").trim())
            .filter(|l| !l.is_empty() && !l.contains('='))
            .map(|l| {
                let (ty, name) = l.split_once(char::is_whitespace).expect("type and name");
                let base = ty.split('[').next().unwrap_or(ty);
                let primitive = base
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit());
                let ty = if ty.contains('/') || primitive {
                    ty.to_string()
                } else {
                    format!("{package}/{ty}")
                };
                (name.trim().to_string(), ty)
            })
            .collect()
    }

    fn owned(fields: Vec<(&'static str, String)>) -> Vec<(String, String)> {
        fields
            .into_iter()
            .map(|(n, t)| (n.to_string(), t))
            .collect()
    }

    /// The parts of a `.srv` or `.action` text between its `---` lines.
    fn parts(text: &str) -> Vec<&str> {
        text.split("\n---\n").collect()
    }

    const GRIPPER_COMMAND_MSG: &str =
        include_str!("../../msg/jazzy/control_msgs/GripperCommand.msg");
    const GRIPPER_COMMAND: &str =
        include_str!("../../msg/jazzy/control_msgs/GripperCommand.action");
    const PARALLEL: &str =
        include_str!("../../msg/jazzy/control_msgs/ParallelGripperCommand.action");
    const JOINT_STATE: &str = include_str!("../../msg/jazzy/sensor_msgs/JointState.msg");
    const GRIP: &str = include_str!("../../../srv/Grip.srv");

    #[test]
    fn the_grip_service_matches_its_srv_file() {
        let grip = parts(GRIP);
        assert_eq!(grip.len(), 2);
        assert_eq!(parse(grip[0], "grasp_orient"), owned(GripRequest::fields()));
        assert_eq!(
            parse(grip[1], "grasp_orient"),
            owned(GripResponse::fields())
        );
    }

    #[test]
    fn gripper_command_matches_control_msgs() {
        assert_eq!(
            parse(GRIPPER_COMMAND_MSG, "control_msgs"),
            owned(GripperCommand::fields())
        );
        let action = parts(GRIPPER_COMMAND);
        assert_eq!(action.len(), 3);
        assert_eq!(
            parse(action[0], "control_msgs"),
            owned(GripperCommandGoal::fields())
        );
        assert_eq!(
            parse(action[1], "control_msgs"),
            owned(GripperCommandResult::fields())
        );
        assert_eq!(
            parse(action[2], "control_msgs"),
            owned(GripperCommandFeedback::fields())
        );
        // The file's own words: the goal's type is the message above, in N for max_effort.
        assert!(GRIPPER_COMMAND.starts_with("GripperCommand command\n"));
    }

    #[test]
    fn parallel_gripper_command_matches_control_msgs() {
        assert_eq!(
            parse(JOINT_STATE, "sensor_msgs"),
            owned(JointState::fields())
        );
        let action = parts(PARALLEL);
        assert_eq!(action.len(), 3);
        assert_eq!(
            parse(action[0], "control_msgs"),
            owned(ParallelGripperGoal::fields())
        );
        assert_eq!(
            parse(action[1], "control_msgs"),
            owned(ParallelGripperResult::fields())
        );
        assert_eq!(
            parse(action[2], "control_msgs"),
            owned(ParallelGripperFeedback::fields())
        );
    }

    /// The goal's bytes as rosidl lays them out: CDR, little-endian, two float64 after the
    /// 4-byte encapsulation header (the 16-byte goal id before them is ros2-client's).
    #[test]
    fn a_gripper_goal_is_two_doubles_on_the_wire() {
        let goal = GripperCommandGoal {
            command: GripperCommand {
                position: 0.25,
                max_effort: 12.5,
            },
        };
        let bytes = crate::msg::cdr::encode(&goal).expect("serializes");
        let mut expected = Vec::new();
        expected.extend_from_slice(&0.25f64.to_le_bytes());
        expected.extend_from_slice(&12.5f64.to_le_bytes());
        assert!(bytes.ends_with(&expected), "{bytes:?}");
    }
}
