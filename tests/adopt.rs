//! Adopting an engine's instance, device and queue (the code of examples/adopt.rs).

#[path = "../examples/adopt.rs"]
mod adopt_example;

#[test]
fn adopted_device_survives_envlight_and_validation_stays_silent() {
    let warnings = adopt_example::run().unwrap();
    assert_eq!(warnings, 0, "validation warnings on the engine's device");
}
