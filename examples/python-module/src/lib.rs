//! Your own vehicles and force laws as a Python module: one macro call
//! turns an [`ezy::App`] into `import my_vehicles`, with the same API as
//! the `ezy` package (`run`, `sweep`, `scene`, `equations`, `check`, ...)
//! over this application's models, effect kinds and scenes.
//!
//! Here: ezy's built-in vehicles, the Roller Racer of `examples/roller-racer`
//! (its model and scene `roller`), and the feedback steering law of
//! `examples/steering` (effect kind `steering`, scene `steer`). Build and
//! install it with `pip install ./examples/python-module` (maturin).

ezy_python::python_module!(
    my_vehicles,
    roller_racer::app()
        .effect::<steering::Steering>("steering")
        .scene("scenes/steer.toml", include_str!("../../steering/scenes/steer.toml"))
);
