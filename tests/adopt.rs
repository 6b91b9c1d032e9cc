//! Adopting an engine's instance, device and queue (the code of examples/adopt.rs), and the
//! examples' engine counting what validation reports while it tears down.

#[path = "../examples/adopt.rs"]
mod adopt_example;

use adopt_example::engine;

#[test]
fn adopted_device_survives_envlight_and_validation_stays_silent() {
    let warnings = adopt_example::run().unwrap();
    assert_eq!(warnings, 0, "validation warnings on the engine's device");
}

/// A buffer the engine forgets to destroy is reported while its device is destroyed, and
/// that report reaches the count [`engine::Engine::finish`] returns: the examples' tests see
/// leaks, not only the messages of the frame.
#[test]
fn a_leak_reported_at_teardown_is_counted() {
    let engine = engine::Engine::new().unwrap();
    let info = ash::vk::BufferCreateInfo::default()
        .size(256)
        .usage(ash::vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: a valid device and create info; the buffer is leaked on purpose.
    let _leaked = unsafe { engine.device.create_buffer(&info, None).unwrap() };
    let before = engine.warnings();
    let after = engine.finish();
    assert_eq!(before, 0, "warnings before teardown");
    assert!(after > 0, "the leaked buffer was not reported at teardown");
}
