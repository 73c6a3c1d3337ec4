//! The floor table of every crate of the house, the one source of the
//! tables in docs/dev/architecture.md (generated from these, see
//! `docs.rs`). A module belongs to the longest module of its crate's
//! table that is a prefix of its path; its floor is that line's. Each
//! floor says below why it is where it is: what its modules import.

use crate::rules::{Door, Floor, Knot, Rules};

const fn f(module: &'static str, floor: u32, holds: &'static str) -> Floor {
    Floor { module, floor, holds }
}

/// The crates, in the order the data flows (the language, the macro, the
/// runtime, the scene, the models, the command line, Python).
pub const CRATES: &[Rules] = &[LANG, DERIVE, CORE, SCENE, MODELS, EZY, PYTHON];

/// `ezy-lang`, the model language's engine.
pub const LANG: Rules = Rules {
    name: "ezy-lang",
    src: "ezy-lang/src",
    root: "lib.rs",
    floors: &[
        // floor 0: import nothing of the crate (the crate root's limits
        // aside)
        f("ast", 0, "the typed model, the user's tokens kept for error spans"),
        f("depth", 0, "how deep a model's text nests, bounded on its tokens before syn parses them"),
        f("sym", 0, "the symbolic engine: the hash-consed arena, differentiation, hoisting, printing"),
        // floor 1: read the syntax tree
        f("parse", 1, "`impl Parse` for the model language"),
        f("check", 1, "a parsed model validated, every error spanned at the user's token"),
        // floor 2: the checked model into expressions
        f("kinematics", 2, "points, hinges and skates into symbolic constraint expressions"),
        f("minimal", 2, "minimal coordinates of a model without families, derived symbolically"),
        // floor 3: the derived expressions in global coordinates
        f("straight", 3, "the straight-line form both back ends evaluate"),
        f(
            "description",
            3,
            "what a derived model says about itself, as data both back ends share: names, where elements sit, what the counts must satisfy, equation templates",
        ),
    ],
    doors: &[],
    knots: &[],
    commands: None,
};

/// `ezy-derive`, the `model!` macro.
pub const DERIVE: Rules = Rules {
    name: "ezy-derive",
    src: "ezy-derive/src",
    root: "lib.rs",
    floors: &[
        // floor 0: neither imports the other; the crate root runs
        // ezy-lang on the macro's tokens, then `emit` (and `dump`)
        f("dump", 0, "`EZY_DUMP_EXPANSION=DIR`: every expansion written out, to diff a refactoring"),
        f(
            "emit",
            0,
            "the back end, split by what it emits (lower, layout, families, straight, products, minimal, describe)",
        ),
    ],
    doors: &[],
    knots: &[],
    commands: None,
};

/// `ezy-core`, the runtime.
pub const CORE: Rules = Rules {
    name: "ezy-core",
    src: "ezy-core/src",
    root: "lib.rs",
    floors: &[
        // floor 0: what everything else speaks; `error` imports only
        // `names` and `settings`
        f("names", 0, "how numbers and names are written in messages and columns"),
        f(
            "settings",
            0,
            "`RunSettings`, `Method`, `Formulation`, `ProjectionKind`, `Choice`, `Setting`, the limits every input is checked against",
        ),
        f(
            "error",
            0,
            "`SimError` (its `Setup(SetupError)` found before the first step, the rest while solving), `KktError`; advice as data (`Message`), spelled by whoever renders it",
        ),
        f("scalar", 0, "the scalar trait the generated code is generic over"),
        f("files", 0, "reading a file a user names: capped, regular files only"),
        f(
            "quantities",
            0,
            "every column the analyses' CSV files write, defined once: unit, definition, formula, frame and time, source (data)",
        ),
        // floor 1: data about a model, and the integrators, which see an
        // `Rhs` and a `NewtonSystem`, never the dynamics
        f("model::info", 1, "what a model is: sizes, names, the pattern of `G` (data)"),
        f("model::layout", 1, "where a model's elements sit at its counts, from its description"),
        f(
            "model::describe",
            1,
            "a model's description rendered at its counts: `ModelInfo`, `check_counts`, `equations` (both back ends)",
        ),
        f(
            "integrator",
            1,
            "RK4, Euler, DOPRI5, DOP853, RADAU5 behind one `Stepper`, over an `Rhs` and a `NewtonSystem`",
        ),
        // floor 2: forces and drives, on a model's description
        f("effects", 2, "force laws: the traits (`kind`), one file per family, the registry, the hot enum (`law`)"),
        f("drive", 2, "prescribed motions"),
        // floor 3: the trait generated models implement (it takes the
        // effects and drives)
        f(
            "model",
            3,
            "the `Model` trait the macro implements; `MinimalCall`, one evaluation of the fused right-hand side",
        ),
        // floor 4: on the `Model` trait: linear algebra, events (data), a
        // model read from text
        f("kkt", 4, "the KKT solvers: dense, Schur complement, sparse"),
        f("events", 4, "what an event is (`events::spec`, data)"),
        f("text", 4, "`RuntimeModel`, a model read from text: plan, tape (and its JIT), fused"),
        // floor 5: the equations a run integrates
        f(
            "formulation",
            5,
            "`dae` (`Dynamics`, the workspace), friction, projection, reduced, initial values, RADAU5's Newton system",
        ),
        // floor 6: the step loop over the formulations
        f(
            "simulate",
            6,
            "the one step loop (`driver`), the run's state, its guards, events located, output, the switches' watch",
        ),
        // floor 7: what a user holds, on the step loop
        f("problem", 7, "what a user holds: the problem and its solution"),
        f("analysis", 7, "steady motions, gaits and their stability, branches and their bifurcations"),
        f("erased", 7, "the type-erased model (`AnyModel`)"),
        // floor 8: built on what a user holds (a problem, its analysis)
        f("sensitivity", 8, "derivatives of runs and gaits with respect to parameters"),
        f("geometry", 8, "the geometry of locomotion: a model, its forces, a simulated gait"),
        // floor 9: design questions on the sensitivities
        f("design", 9, "fits and optimization on the sensitivities"),
        f("plan", 9, "least-effort maneuvers by multiple shooting on the sensitivities"),
    ],
    doors: &[
        Door {
            module: "__private",
            reason: "what `model!`'s expansion names in the user's crate (through `$crate`), re-exported",
        },
        Door {
            module: "__private::describe",
            reason: "the description `model!` writes as a `static` (`ezy_lang::description`) and the functions that render it, re-exported",
        },
    ],
    knots: &[
        Knot {
            item: "effects::law::Law",
            reason: "the hot enum over the families' law structs (static dispatch, see effects/law.rs) names each family's file, and `ForceLaw::into_law` returns it: each family's override names its own variant",
        },
        Knot {
            item: "effects::law::UserLaw",
            reason: "the default `ForceLaw::into_law` (effects/kind.rs) keeps a law of the user's own in the hot enum's `User` variant",
        },
    ],
    commands: None,
};

/// `ezy-scene`, the scene document.
pub const SCENE: Rules = Rules {
    name: "ezy-scene",
    src: "ezy-scene/src",
    root: "lib.rs",
    floors: &[
        // floor 0: import nothing of the crate
        f("error", 0, "what is wrong with a scene and where (`SceneError`, `SceneFileError`)"),
        f("kinds", 0, "effects as scene files write them; kinds of the user's own"),
        f("view", 0, "figure specs (data)"),
        f("units", 0, "unit suffixes on numbers: the table, the conversion to SI, the dimension checks"),
        // floor 1: the document, made of the effects and the figures
        f("schema", 1, "the document's types (`Scene`), the output groups among them"),
        // floor 2: on the document
        f("bind", 2, "scene parameters, `--set`, phase steps"),
        f("columns", 2, "each output group's column names and values, side by side in one match"),
        f("parameter", 2, "a scene's numbers as parameters of its problem"),
        // floor 3: the file (text in and out, through the bindings) and
        // the check (through the columns)
        f("file", 3, "the scene file: its text read into a `Scene` and written back, errors placed in it"),
        f("check", 3, "the check against the model, one module per section, into a `Checked` scene"),
        f("family", 3, "family expansion (`hinge = \"J[*]\"`)"),
        // floor 4: models by key, their scenes checked
        f("registry", 4, "models by the key scenes name them by; a scene file checked against them"),
        // floor 5: the checked scene into what the runtime takes
        f("problem", 5, "`Checked -> Problem`"),
    ],
    doors: &[],
    knots: &[],
    commands: None,
};

/// `ezy-models`, the built-in vehicles and mechanisms.
pub const MODELS: Rules = Rules {
    name: "ezy-models",
    src: "models/src",
    root: "lib.rs",
    floors: &[
        // floor 0: one file per vehicle; none imports another
        f("chaplygin_sleigh", 0, "the Chaplygin sleigh"),
        f("ezyroller", 0, "the EzyRoller"),
        f("ezyroller_driven", 0, "the EzyRoller with its steering driven"),
        f("kinematic_snake", 0, "the kinematic snake"),
        f("mechanisms", 0, "pendulums, four-bars, a slider-crank"),
        f("snake", 0, "the snake of N links, free, driven and servoed"),
        f("snakeboard", 0, "the snakeboard"),
        f("trailer", 0, "a car with trailers"),
        // floor 1: the scenes read the vehicles (through the crate root's
        // registration); no vehicle reads a scene
        f("scenes", 1, "the built-in scene files, embedded, checked against the built-in models"),
    ],
    doors: &[],
    knots: &[],
    commands: None,
};

/// `ezy`, the facade and the command line: what writes files and draws
/// below what the commands share, the work the commands call above that,
/// then the catalog and the shared parsers, the commands, and on top the
/// dispatch that looks a command up in their table (as cargo's
/// `src/bin/cargo/`).
pub const EZY: Rules = Rules {
    name: "ezy",
    src: "src",
    root: "lib.rs",
    floors: &[
        // floor 0: import nothing of the crate
        f("output", 0, "csv, the output transaction (a locked directory, commit, signals), progress"),
        f("testing", 0, "checks of a model's derived terms, for its author's tests"),
        // floor 1: drawing writes through the output
        f(
            "render",
            1,
            "plot/ (series, chart, axis, lines, legend, heat map, snap, raster), figures, animation, report",
        ),
        // floor 2: what the commands share, drawing included
        f(
            "session",
            2,
            "what commands share: run options, settings, the problem of a scene, the report and its summary",
        ),
        // floor 3: the work the commands call (cargo's `ops/`)
        f("run", 3, "a scene's run: its output directory, rows and figures"),
        f("precision", 3, "the precision ladder"),
        f("sweep", 3, "runs over parameter values: plans, shards, the table, figures"),
        // floor 4: the shared argument parsers and the catalog
        f("cli", 4, "the shared argument parsers and overrides"),
        f("app", 4, "the catalog of models and scenes (`App`)"),
        // floor 5: one file per command
        f("commands", 5, "one file per command (its clap arguments and its `exec`), one table in `commands/mod.rs`"),
        // floor 6: the dispatch over the commands' table
        f("app::dispatch", 6, "`App::main`, `App::run_cli`: parse, look the command up in the table, run it"),
    ],
    doors: &[],
    knots: &[],
    commands: Some("commands"),
};

/// `ezy-python`, the Python module (pyo3).
pub const PYTHON: Rules = Rules {
    name: "ezy-python",
    src: "python/src",
    root: "lib.rs",
    floors: &[
        // floor 0: import nothing of the crate (the crate root's error
        // aside)
        f("reports", 0, "what `equations`, `check`, `analyze` and `linearize` return"),
        f("scene_text", 0, "scenes made in Python as scene-file text"),
        f("settings", 0, "the run keywords, turned into what the command line's flags would give"),
        f("units", 0, "each output column's unit and meaning"),
        f("quantities", 0, "each analysis table's columns' units and meanings, from ezy-core's table of quantities"),
        f("words", 0, "the command line's text as a call from Python says it: flags as keywords, files as attributes"),
        // floor 1: on the keywords and the reports
        f("kit", 1, "the application behind a module (`Toolkit`), the command line run with the GIL released"),
        f("result", 1, "`ezy.Result`, a finished run in memory"),
        f("sweep", 1, "`ezy.sweep`'s grid as the command line's arguments"),
        // floor 2: a model's equations through the kit's command line
        f("model", 2, "`ezy.Model`, a vehicle from the text of a model"),
        // floor 3: on a model and the kit
        f("command", 3, "a command on a scene through the command line; a quantity of the caller's Python code"),
        f("scene", 3, "`ezy.Scene` and `ezy.Effect`, a scene to change and run"),
        f("planning", 3, "`plan` and `gait_optimize` through the command line; a call on a scene or a model"),
        // floor 4: the module's functions, over everything
        f("toolkit", 4, "the module's functions, `Toolkit`'s methods"),
    ],
    doors: &[],
    knots: &[],
    commands: None,
};
