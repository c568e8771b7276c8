//! SYMORO `.par` files as SYMORO writes them, each against an evaluation
//! written here from the geometry alone (1e-9 m, 1e-9 on rotation entries):
//! the Stanford arm with `Mu = 0` on every joint (a robot without loops:
//! every joint actuated), and a two-cylinder excavator arm (two loops, `cos`
//! and `sin` in its `B` and `d` entries) over a box 30 deg and 30 % of each
//! cylinder's stroke from its home configuration, its loops followed by
//! continuation from home (a fresh workspace per configuration) and from the
//! previous row of a batch. Expression errors point at the character.

use std::f64::consts::{FRAC_PI_2, PI};
use std::path::PathBuf;

use flexcal_kinematics::{
    Data, ImportOptions, ImportedRobot, KinematicsError, forward_frames, forward_pose,
};
use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

fn symoro(file: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/symoro")
        .join(file)
}

fn import(par: &str, values: &str) -> ImportedRobot {
    let options = ImportOptions {
        values: Some(symoro(values)),
        ..ImportOptions::default()
    };
    ImportedRobot::read_par(&symoro(par), &options).unwrap()
}

/// Largest position (m) and rotation-entry differences.
fn difference(a: &Isometry3<f64>, b: &Isometry3<f64>) -> (f64, f64) {
    let dp = (a.translation.vector - b.translation.vector).amax();
    let dr = (a.rotation.to_rotation_matrix().matrix() - b.rotation.to_rotation_matrix().matrix())
        .amax();
    (dp, dr)
}

/// One Khalil-Kleinfinger frame transform with gamma = b = 0:
/// `Rx(alpha) Tx(d) Rz(theta) Tz(r)`, from elementary nalgebra transforms.
fn kk(alpha: f64, d: f64, theta: f64, r: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_euler_angles(alpha, 0.0, 0.0),
    ) * Isometry3::translation(d, 0.0, 0.0)
        * Isometry3::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_euler_angles(0.0, 0.0, theta),
        )
        * Isometry3::translation(0.0, 0.0, r)
}

#[test]
fn stanford_arm_written_with_mu_zero_is_a_six_joint_arm() {
    let imported = import("stanford_mu0.par", "stanford_mu0_values.toml");
    assert!(
        imported
            .notes
            .iter()
            .any(|n| n.contains("mu = 0") && n.contains("actuated")),
        "the import says how mu = 0 was read: {:?}",
        imported.notes
    );
    let model = imported.description.build().unwrap();
    assert_eq!(
        model.actuated_names(),
        ["th1", "th2", "r3", "th4", "th5", "th6"]
    );
    let (rl2, rl7) = (0.161925, 0.2);
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let mut worst = (0.0f64, 0.0f64);
    for k in 0..50 {
        let t = k as f64;
        let q = [
            (0.7 * t).sin() * 2.5,
            (1.1 * t).cos() * 1.5,
            0.2 + 0.3 * (0.5 * t).sin(),
            (1.7 * t).sin() * 3.0,
            (0.3 * t).cos() * 1.8,
            (2.3 * t).sin() * 3.0,
        ];
        let expected = kk(0.0, 0.0, q[0], 0.0)
            * kk(-FRAC_PI_2, 0.0, q[1], rl2)
            * kk(FRAC_PI_2, 0.0, 0.0, q[2])
            * kk(0.0, 0.0, q[3], 0.0)
            * kk(-FRAC_PI_2, 0.0, q[4], 0.0)
            * kk(FRAC_PI_2, 0.0, q[5], 0.0)
            * kk(0.0, 0.0, 0.0, rl7);
        let x = forward_pose(&model, &mut data, &q, &xi).unwrap();
        let (dp, dr) = difference(&x, &expected);
        worst = (worst.0.max(dp), worst.1.max(dr));
    }
    assert!(worst.0 < 1e-9 && worst.1 < 1e-9, "{worst:?}");
}

/// The excavator's dimensions, as in `excavator_values.toml` (m, rad).
struct Excavator {
    h0: f64,
    d2: f64,
    l2: f64,
    l3: f64,
    ra: f64,
    pa: f64,
    d9: f64,
    g9: f64,
    c6: f64,
    g6: f64,
    c10: f64,
    g10: f64,
}

const EXCAVATOR: Excavator = Excavator {
    h0: 0.6,
    d2: 0.15,
    l2: 2.4,
    l3: 1.6,
    ra: 0.5,
    pa: 2.2,
    d9: 1.0,
    g9: -0.15,
    c6: 0.9,
    g6: 0.25,
    c10: 0.45,
    g10: 2.6,
};

fn direction(angle: f64) -> [f64; 2] {
    [angle.cos(), angle.sin()]
}

fn plus(p: [f64; 2], length: f64, angle: f64) -> [f64; 2] {
    let u = direction(angle);
    [p[0] + length * u[0], p[1] + length * u[1]]
}

/// The angle `alpha` that puts `centre + lever * direction(alpha)` at the
/// distance `length` from `pivot` (law of cosines), on assembly `branch`.
fn triangle(centre: [f64; 2], lever: f64, pivot: [f64; 2], length: f64, branch: f64) -> f64 {
    let w = [pivot[0] - centre[0], pivot[1] - centre[1]];
    let rho = w[0].hypot(w[1]);
    let cosine = (lever * lever + rho * rho - length * length) / (2.0 * lever * rho);
    assert!(
        cosine.abs() < 0.95,
        "the box stays clear of the dead points: {cosine}"
    );
    w[1].atan2(w[0]) + branch * cosine.acos()
}

impl Excavator {
    /// Boom and stick angles (in the slew body's vertical plane, from the
    /// horizontal and from the boom) for cylinder lengths `r5`, `r7` on the
    /// assembly `branches`.
    fn angles(&self, r5: f64, r7: f64, branches: [f64; 2]) -> (f64, f64) {
        let boom_pivot = [self.d2, 0.0];
        let cylinder_pivot = [self.ra * self.pa.sin(), self.ra * self.pa.cos()];
        let th2 = triangle(boom_pivot, self.d9, cylinder_pivot, r5, branches[0]) - self.g9;
        let stick_joint = plus(boom_pivot, self.l2, th2);
        let stick_pivot = plus(boom_pivot, self.c6, th2 + self.g6);
        let th3 = triangle(stick_joint, self.c10, stick_pivot, r7, branches[1]) - self.g10 - th2;
        (th2, th3)
    }

    /// The home branch: the assembly whose boom and stick angles at the
    /// home cylinder lengths (0.94 and 1.53 m) are the values file's home
    /// values (0.5 and -1.0 rad, to 0.05 rad).
    fn home_branches(&self) -> [f64; 2] {
        [[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]]
            .into_iter()
            .find(|&b| {
                let (th2, th3) = self.angles(0.94, 1.53, b);
                wrapped(th2 - 0.5).abs() < 0.05 && wrapped(th3 + 1.0).abs() < 0.05
            })
            .expect("one branch is the home configuration")
    }

    /// Pose of the tool frame 8 in the base frame.
    fn tool(&self, th1: f64, th2: f64, th3: f64) -> Isometry3<f64> {
        let stick_joint = plus([self.d2, 0.0], self.l2, th2);
        let [u, v] = plus(stick_joint, self.l3, th2 + th3);
        let (x1, y1, z1) = (
            Vector3::new(th1.cos(), th1.sin(), 0.0),
            Vector3::new(-th1.sin(), th1.cos(), 0.0),
            Vector3::z(),
        );
        let p = u * x1 + (self.h0 + v) * z1;
        let [c, s] = direction(th2 + th3);
        let x8 = c * x1 + s * z1;
        let z8 = -y1;
        let rotation = Matrix3::from_columns(&[x8, z8.cross(&x8), z8]);
        Isometry3::from_parts(
            Translation3::from(p),
            UnitQuaternion::from_matrix(&rotation),
        )
    }
}

fn wrapped(angle: f64) -> f64 {
    (angle + PI).rem_euclid(2.0 * PI) - PI
}

#[test]
fn two_cylinder_arm_follows_its_home_branch_over_the_box() {
    let imported = import("excavator.par", "excavator_values.toml");
    let model = imported.description.build().unwrap();
    assert_eq!(model.actuated_names(), ["th1", "r5", "r7"]);
    let home = [0.0, 0.94, 1.53];
    assert_eq!(model.home_configuration(), Some(&home[..]));
    let xi = model.nominal_params().to_vec();
    let e = EXCAVATOR;
    let branches = e.home_branches();
    let stroke = 0.6;
    let steps = [-1.0, -0.5, 0.0, 0.5, 1.0];
    let mut batch = Data::new(&model);
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    let mut count = 0;
    for a in steps {
        for b in steps {
            for c in steps {
                let q = [
                    a * 30f64.to_radians(),
                    home[1] + b * 0.3 * stroke,
                    home[2] + c * 0.3 * stroke,
                ];
                let (th2, th3) = e.angles(q[1], q[2], branches);
                let expected = e.tool(q[0], th2, th3);
                // From home (a fresh workspace) and from the previous row.
                let mut fresh = Data::new(&model);
                forward_frames(&model, &mut fresh, &q, &xi).unwrap();
                let x_fresh = forward_pose(&model, &mut fresh, &q, &xi).unwrap();
                let x_batch = forward_pose(&model, &mut batch, &q, &xi).unwrap();
                for x in [x_fresh, x_batch] {
                    let (dp, dr) = difference(&x, &expected);
                    worst.0 = worst.0.max(dp);
                    worst.1 = worst.1.max(dr);
                }
                let joints = fresh.joint_values();
                let (f2, f3) = (
                    model.frame_index("2").unwrap(),
                    model.frame_index("3").unwrap(),
                );
                worst.2 = worst
                    .2
                    .max(wrapped(joints[f2] - th2).abs())
                    .max(wrapped(joints[f3] - th3).abs());
                count += 1;
            }
        }
    }
    assert_eq!(count, 125);
    assert!(
        worst.0 < 1e-9 && worst.1 < 1e-9 && worst.2 < 1e-9,
        "position, rotation, joint angles: {worst:?}"
    );
}

#[test]
fn the_boom_cylinders_dead_point_is_named_a_singular_loop_jacobian() {
    let model = import("excavator.par", "excavator_values.toml")
        .description
        .build()
        .unwrap();
    let xi = model.nominal_params().to_vec();
    let e = EXCAVATOR;
    // The boom cylinder is in line with its lever when its length is the
    // lever minus the distance between the two pivots.
    let pivots = (e.ra * e.pa.sin() - e.d2).hypot(e.ra * e.pa.cos());
    let dead = e.d9 - pivots;
    let q = [0.0, dead - 0.1, 1.53];
    let mut data = Data::new(&model);
    match forward_frames(&model, &mut data, &q, &xi) {
        Err(KinematicsError::LoopSingular(singular)) => {
            assert_eq!(singular.loop_name, "loop1");
            assert_eq!(singular.from, [0.0, 0.94, 1.53]);
            assert_eq!(singular.q, q);
            let at = singular.at[1];
            assert!((at - dead).abs() < 1e-5, "{at} against {dead}");
        }
        other => panic!("expected a singular loop Jacobian, got {other:?}"),
    }
    // The workspace keeps its branch: the next configuration is assembled.
    let q = [0.1, 0.9, 1.5];
    let (th2, th3) = e.angles(q[1], q[2], e.home_branches());
    let x = forward_pose(&model, &mut data, &q, &xi).unwrap();
    let (dp, dr) = difference(&x, &e.tool(q[0], th2, th3));
    assert!(dp < 1e-9 && dr < 1e-9, "{dp:e} {dr:e}");
}

#[test]
fn expression_errors_point_at_the_character() {
    let text = |b: &str| {
        format!(
            "NL = 1\nNJ = 1\nNF = 1\nAnt = {{0}}\nSigma = {{0}}\nMu = {{0}}\nB = {{{b}}}\nTheta = {{th1}}\n"
        )
    };
    let read = |b: &str| ImportedRobot::from_par_str(&text(b), "f.par", &ImportOptions::default());
    // Functions, powers, unary minus and pi are read.
    let ok =
        read("-2^2 + 3**2 + sqrt(16) + atan2(1, 1)*4/Pi + cos(0) - Sin[pi/2] + tan(0)").unwrap();
    let b_mm = ok.description.frames[0].b_mm;
    assert!(
        (b_mm - 1e3 * (-4.0 + 9.0 + 4.0 + 1.0 + 1.0 - 1.0)).abs() < 1e-9,
        "{b_mm}"
    );
    for (entry, expected) in [
        (
            "d12*cos(g12))",
            "unexpected text after the expression at character 13 (`)`)",
        ),
        (
            "cosh(1)",
            "unknown function `cosh` (known: sin, cos, tan, sqrt, atan2) at character 1",
        ),
        (
            "2 * (1 + ",
            "an operand is missing at the end of `2 * (1 +`",
        ),
        ("atan2(1)", "`atan2` takes 2 argument(s), found 1"),
        ("1 $ 2", "at character 3 (`$`)"),
    ] {
        let message = read(entry).unwrap_err().to_string();
        assert!(
            message.starts_with("f.par:7: b of frame 1:") && message.contains(expected),
            "{entry}: {message}"
        );
    }
}
