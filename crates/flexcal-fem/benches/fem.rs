//! Speed goals of flexcal-fem:
//! * a robot-like chain of 11 nodes (60 free DOFs, 5 beams and 5 joint
//!   springs), re-positioned, assembled and condensed onto its TCP for every
//!   configuration: goal <= 20 us;
//! * a 1 000-DOF space frame assembled, factored and solved: goal <= 5 ms
//!   (also a 1 092-DOF flat grillage, whose ordering is less favourable).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use flexcal_fem::{
    Beam, Factorization, Joint, LoadCase, Section, SolverOptions, Structure, assemble_and_factor,
    load_vector,
};
use nalgebra::{Rotation3, Unit, Vector3, Vector6};

fn steel(scale: f64) -> Section {
    Section {
        youngs_modulus: 2.1e11,
        shear_modulus: 8.1e10,
        area: 8e-3 * scale,
        iy: 6e-5 * scale,
        iz: 5e-5 * scale,
        torsion_constant: 1e-4 * scale,
        shear_area_y: Some(6e-3 * scale),
        shear_area_z: Some(6e-3 * scale),
    }
}

/// Joint axes in the zero configuration and link vectors, like a 5-axis arm.
const AXES: [[f64; 3]; 5] = [
    [0.0, 0.0, 1.0],
    [0.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
];
const LINKS: [[f64; 3]; 5] = [
    [0.3, 0.0, 0.7],
    [0.0, 0.0, 1.1],
    [1.0, 0.0, 0.2],
    [0.3, 0.0, 0.0],
    [0.25, 0.0, 0.0],
];

/// Node positions, joint axes and beam orientation vectors of the chain at
/// joint angles `q`.
struct ChainPose {
    positions: Vec<Vector3<f64>>,
    axes: Vec<Vector3<f64>>,
    vecxz: Vec<Vector3<f64>>,
}

fn chain_pose(q: &[f64; 5]) -> ChainPose {
    let mut rotation = Rotation3::identity();
    let mut point = Vector3::zeros();
    let mut positions = vec![point];
    let mut axes = Vec::new();
    let mut vecxz = Vec::new();
    for k in 0..5 {
        let axis_zero = Vector3::from(AXES[k]);
        let axis = rotation * axis_zero;
        rotation = Rotation3::from_axis_angle(&Unit::new_normalize(axis), q[k]) * rotation;
        axes.push(axis);
        positions.push(point); // the joint's second node, coincident
        let link = rotation * Vector3::from(LINKS[k]);
        let side = if link.normalize().dot(&Vector3::z()).abs() > 0.9 {
            Vector3::x()
        } else {
            Vector3::z()
        };
        vecxz.push(side);
        point += link;
        positions.push(point);
    }
    ChainPose {
        positions,
        axes,
        vecxz,
    }
}

fn chain() -> (Structure, usize) {
    let pose = chain_pose(&[0.0; 5]);
    let mut s = Structure::new();
    for (n, p) in pose.positions.iter().enumerate() {
        s.add_node(format!("n{n}"), *p).unwrap();
    }
    s.set_support(0, [true; 6]).unwrap();
    for k in 0..5 {
        s.add_joint(Joint {
            name: format!("joint{k}"),
            i: 2 * k,
            j: 2 * k + 1,
            axis: pose.axes[k],
            local_y: None,
            stiffness: [1e10, 1e10, 1e10, 2e6 / (k + 1) as f64, 1e9, 1e9],
        })
        .unwrap();
        s.add_beam(Beam {
            name: format!("link{k}"),
            i: 2 * k + 1,
            j: 2 * k + 2,
            section: steel(1.0 / (k + 1) as f64),
            vecxz: pose.vecxz[k],
            releases: [false; 12],
            mass_per_length: 0.0,
        })
        .unwrap();
    }
    (s, 10)
}

fn bench_chain(c: &mut Criterion) {
    let (mut s, tcp) = chain();
    let mut fact = Factorization::new(&s, &SolverOptions::condensing_onto(tcp)).unwrap();
    assert_eq!(fact.equation_count(), 60);
    let poses: Vec<ChainPose> = (0..64)
        .map(|k| {
            let t = k as f64 * 0.1;
            chain_pose(&[
                t.sin(),
                0.3 * t.cos(),
                -0.5 + 0.2 * t.sin(),
                t,
                0.7 * t.cos(),
            ])
        })
        .collect();
    let mut k = 0;
    c.bench_function(
        "chain 60 DOF: move + assemble + condense (K_eq, C_eq)",
        |b| {
            b.iter(|| {
                let pose = &poses[k % poses.len()];
                k += 1;
                for (n, p) in pose.positions.iter().enumerate() {
                    s.set_node_position(n, *p).unwrap();
                }
                for j in 0..5 {
                    s.set_joint_frame(j, pose.axes[j], None).unwrap();
                    s.set_beam_vecxz(j, pose.vecxz[j]).unwrap();
                }
                assemble_and_factor(&s, &mut fact).unwrap();
                black_box((fact.k_eq().unwrap(), fact.c_eq().unwrap()))
            })
        },
    );
}

/// A space frame of `columns x columns` columns and `levels` storeys, the
/// ground level clamped; returns the structure and a top node.
fn tower(columns: usize, levels: usize) -> (Structure, usize) {
    let mut s = Structure::new();
    let spacing = 3.0;
    let height = 3.5;
    let index = |level: usize, a: usize, b: usize| level * columns * columns + a * columns + b;
    for level in 0..=levels {
        for a in 0..columns {
            for b in 0..columns {
                let p = Vector3::new(
                    a as f64 * spacing,
                    b as f64 * spacing,
                    level as f64 * height,
                );
                let n = s.add_node(format!("n{level}_{a}_{b}"), p).unwrap();
                if level == 0 {
                    s.set_support(n, [true; 6]).unwrap();
                }
            }
        }
    }
    let mut count = 0;
    let mut add = |s: &mut Structure, i: usize, j: usize, vecxz: Vector3<f64>, scale: f64| {
        count += 1;
        s.add_beam(Beam {
            name: format!("b{count}"),
            i,
            j,
            section: steel(scale),
            vecxz,
            releases: [false; 12],
            mass_per_length: 60.0,
        })
        .unwrap();
    };
    for level in 1..=levels {
        for a in 0..columns {
            for b in 0..columns {
                add(
                    &mut s,
                    index(level - 1, a, b),
                    index(level, a, b),
                    Vector3::x(),
                    2.0,
                );
                if a + 1 < columns {
                    add(
                        &mut s,
                        index(level, a, b),
                        index(level, a + 1, b),
                        Vector3::z(),
                        1.0,
                    );
                }
                if b + 1 < columns {
                    add(
                        &mut s,
                        index(level, a, b),
                        index(level, a, b + 1),
                        Vector3::z(),
                        1.0,
                    );
                }
            }
        }
    }
    (s, index(levels, columns - 1, columns - 1))
}

fn bench_frame(c: &mut Criterion) {
    let (s, top) = tower(3, 19);
    let mut fact = Factorization::new(&s, &SolverOptions::default()).unwrap();
    assert!(fact.equation_count() >= 1000);
    let mut case = LoadCase::new("wind and weight");
    case.gravity = Vector3::new(0.0, 0.0, -9.81);
    case.nodal_loads
        .push((top, Vector6::new(5e3, 2e3, 0.0, 0.0, 0.0, 0.0)));
    let f = load_vector(&s, &case).unwrap();
    let mut u = vec![0.0; s.dof_count()];
    let name = format!(
        "frame {} DOF (profile {} entries): assemble + factor + solve",
        fact.equation_count(),
        fact.profile_size()
    );
    c.bench_function(&name, |b| {
        b.iter(|| {
            assemble_and_factor(&s, &mut fact).unwrap();
            fact.solve_into(black_box(&f), &mut u).unwrap();
            black_box(u[6 * top])
        })
    });
    c.bench_function("frame: one more right-hand side", |b| {
        b.iter(|| {
            fact.solve_into(black_box(&f), &mut u).unwrap();
            black_box(u[6 * top])
        })
    });
}

/// A square grillage of `side x side` nodes in the x-y plane, beams along
/// both directions, clamped along one edge: a wide profile for the ordering.
fn grillage(side: usize) -> (Structure, usize) {
    let mut s = Structure::new();
    for a in 0..side {
        for b in 0..side {
            let n = s
                .add_node(format!("g{a}_{b}"), Vector3::new(a as f64, b as f64, 0.0))
                .unwrap();
            if a == 0 {
                s.set_support(n, [true; 6]).unwrap();
            }
        }
    }
    let mut count = 0;
    for a in 0..side {
        for b in 0..side {
            for (da, db) in [(1, 0), (0, 1)] {
                if a + da < side && b + db < side {
                    count += 1;
                    s.add_beam(Beam {
                        name: format!("b{count}"),
                        i: a * side + b,
                        j: (a + da) * side + b + db,
                        section: steel(1.0),
                        vecxz: Vector3::z(),
                        releases: [false; 12],
                        mass_per_length: 60.0,
                    })
                    .unwrap();
                }
            }
        }
    }
    (s, side * side - 1)
}

fn bench_grillage(c: &mut Criterion) {
    let (s, corner) = grillage(14);
    let mut fact = Factorization::new(&s, &SolverOptions::default()).unwrap();
    let mut case = LoadCase::new("weight");
    case.gravity = Vector3::new(0.0, 0.0, -9.81);
    case.nodal_loads
        .push((corner, Vector6::new(0.0, 0.0, -1e3, 0.0, 0.0, 0.0)));
    let f = load_vector(&s, &case).unwrap();
    let mut u = vec![0.0; s.dof_count()];
    let name = format!(
        "grillage {} DOF (profile {} entries): assemble + factor + solve",
        fact.equation_count(),
        fact.profile_size()
    );
    c.bench_function(&name, |b| {
        b.iter(|| {
            assemble_and_factor(&s, &mut fact).unwrap();
            fact.solve_into(black_box(&f), &mut u).unwrap();
            black_box(u[6 * corner + 2])
        })
    });
}

criterion_group!(benches, bench_chain, bench_frame, bench_grillage);
criterion_main!(benches);
