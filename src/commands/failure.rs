//! The binary's one error type: a failure, its category, and the exit code the category decides.

use fleetdyn::settings::InvalidSetting;
use std::fmt::Display;

/// What kind of failure ended a command; it decides the exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Category {
    /// Bad arguments or configuration files (pipeline, vehicle, mapping, rules): exit 2.
    Usage,
    /// An input (drive, road file, measurement) could not be used, or a drive of a run
    /// failed: exit 1.
    Input,
    /// Reading or writing the file system failed (an output that cannot be written): exit 3.
    Io,
    /// A model, simulation or fit could not be evaluated: exit 4.
    Model,
}

impl Category {
    /// The process exit code of this category.
    pub fn exit_code(self) -> u8 {
        match self {
            Category::Input => 1,
            Category::Usage => 2,
            Category::Io => 3,
            Category::Model => 4,
        }
    }
}

/// A failure and its category.
#[derive(Debug)]
pub struct Failure {
    /// What kind of failure.
    pub category: Category,
    /// The error, as the user reads it.
    pub error: anyhow::Error,
}

fn failure(category: Category, e: impl Into<anyhow::Error>) -> Failure {
    Failure {
        category,
        error: e.into(),
    }
}

/// A usage or configuration error.
pub fn usage(e: impl Into<anyhow::Error>) -> Failure {
    failure(Category::Usage, e)
}

/// A usage error from a message.
pub fn usage_msg(msg: impl Display) -> Failure {
    failure(Category::Usage, anyhow::anyhow!("{msg}"))
}

/// An input that could not be used.
pub fn input(e: impl Into<anyhow::Error>) -> Failure {
    failure(Category::Input, e)
}

/// A file-system failure.
pub fn io(e: impl Into<anyhow::Error>) -> Failure {
    failure(Category::Io, e)
}

/// A model that could not be evaluated.
pub fn model(e: impl Into<anyhow::Error>) -> Failure {
    failure(Category::Model, e)
}

/// A setting out of range, named as the command-line flag that set it.
pub fn setting(e: InvalidSetting) -> Failure {
    usage_msg(format_args!("{} {}: {}", e.flag(), e.value, e.rule))
}
