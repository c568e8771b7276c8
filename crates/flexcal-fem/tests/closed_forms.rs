//! Solutions of flexcal-fem against closed forms of beam theory.

use approx::assert_relative_eq;
use flexcal_fem::{
    Beam, Dof, Factorization, FemError, Joint, LoadCase, Section, SolverOptions, Structure,
    assemble_and_factor, load_vector, reactions, solve_load_case,
};
use nalgebra::{Matrix3, Matrix6, Rotation3, Vector3, Vector6};

const E: f64 = 210e9;
const G: f64 = 80e9;
const AREA: f64 = 2e-3;
const IY: f64 = 3e-6;
const IZ: f64 = 1e-6;
const TORSION: f64 = 2.5e-6;

fn section() -> Section {
    Section {
        youngs_modulus: E,
        shear_modulus: G,
        area: AREA,
        iy: IY,
        iz: IZ,
        torsion_constant: TORSION,
        shear_area_y: None,
        shear_area_z: None,
    }
}

fn beam(name: &str, i: usize, j: usize, section: Section, vecxz: Vector3<f64>) -> Beam {
    Beam {
        name: name.to_string(),
        i,
        j,
        section,
        vecxz,
        releases: [false; 12],
        mass_per_length: 0.0,
    }
}

/// A cantilever of `elements` beams from the origin along `rotation * x`,
/// with local z along `rotation * z`; returns the structure and the tip node.
fn cantilever(
    length: f64,
    elements: usize,
    section: Section,
    rotation: &Matrix3<f64>,
) -> (Structure, usize) {
    let mut s = Structure::new();
    let x = rotation * Vector3::x();
    let mut previous = s.add_node("n0", Vector3::zeros()).unwrap();
    s.set_support(previous, [true; 6]).unwrap();
    for k in 1..=elements {
        let node = s
            .add_node(format!("n{k}"), x * (length * k as f64 / elements as f64))
            .unwrap();
        s.add_beam(beam(
            &format!("b{k}"),
            previous,
            node,
            section,
            rotation * Vector3::z(),
        ))
        .unwrap();
        previous = node;
    }
    (s, previous)
}

fn tip_case(tip: usize, local_wrench: Vector6<f64>, rotation: &Matrix3<f64>) -> LoadCase {
    let mut case = LoadCase::new("tip");
    let f = rotation * local_wrench.fixed_rows::<3>(0);
    let m = rotation * local_wrench.fixed_rows::<3>(3);
    case.nodal_loads
        .push((tip, Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z)));
    case
}

fn node_displacement(u: &[f64], node: usize) -> Vector6<f64> {
    Vector6::from_row_slice(&u[6 * node..6 * node + 6])
}

/// Expected tip displacement (local axes) of a cantilever under a tip wrench
/// in local axes, Euler-Bernoulli with Iy != Iz.
fn expected_tip(length: f64, w: &Vector6<f64>) -> Vector6<f64> {
    let l = length;
    let (fx, fy, fz, mx, my, mz) = (w[0], w[1], w[2], w[3], w[4], w[5]);
    Vector6::new(
        fx * l / (E * AREA),
        fy * l.powi(3) / (3.0 * E * IZ) + mz * l * l / (2.0 * E * IZ),
        fz * l.powi(3) / (3.0 * E * IY) - my * l * l / (2.0 * E * IY),
        mx * l / (G * TORSION),
        -fz * l * l / (2.0 * E * IY) + my * l / (E * IY),
        fy * l * l / (2.0 * E * IZ) + mz * l / (E * IZ),
    )
}

fn rotate6(rotation: &Matrix3<f64>, v: &Vector6<f64>) -> Vector6<f64> {
    let a = rotation * v.fixed_rows::<3>(0);
    let b = rotation * v.fixed_rows::<3>(3);
    Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

#[test]
fn cantilever_under_each_tip_wrench_component_axis_aligned_and_oblique() {
    let length = 1.7;
    let oblique = Rotation3::from_euler_angles(0.3, -0.7, 1.1).into_inner();
    for rotation in [Matrix3::identity(), oblique] {
        for elements in [1, 3] {
            let (s, tip) = cantilever(length, elements, section(), &rotation);
            for component in 0..6 {
                let mut w = Vector6::zeros();
                w[component] = if component < 3 { 1200.0 } else { 350.0 };
                let u = solve_load_case(&s, &tip_case(tip, w, &rotation)).unwrap();
                let expected = rotate6(&rotation, &expected_tip(length, &w));
                let got = node_displacement(&u, tip);
                assert_relative_eq!(got, expected, epsilon = 1e-12, max_relative = 1e-9);
            }
        }
    }
}

#[test]
fn own_weight_of_a_cantilever_gives_w_l4_over_8_e_i() {
    let length = 2.0;
    let mass_per_length = 15.0;
    for elements in [1, 4] {
        let (mut s, tip) = cantilever(length, elements, section(), &Matrix3::identity());
        let mut weighted = Structure::new();
        for n in 0..s.node_count() {
            weighted.add_node(s.node_name(n), s.positions()[n]).unwrap();
            weighted.set_support(n, s.supports()[n]).unwrap();
        }
        for b in s.beams() {
            let mut b = b.clone();
            b.mass_per_length = mass_per_length;
            weighted.add_beam(b).unwrap();
        }
        s = weighted;
        let mut case = LoadCase::new("gravity");
        case.gravity = Vector3::new(0.0, -9.81, 0.0);
        let u = solve_load_case(&s, &case).unwrap();
        let w = mass_per_length * 9.81;
        assert_relative_eq!(
            u[6 * tip + 1],
            -w * length.powi(4) / (8.0 * E * IZ),
            max_relative = 1e-10
        );
        assert_relative_eq!(
            u[6 * tip + 5],
            -w * length.powi(3) / (6.0 * E * IZ),
            max_relative = 1e-10
        );
        // Gravity along the beam stretches it by w L^2 / (2 E A).
        case.gravity = Vector3::new(9.81, 0.0, 0.0);
        let u = solve_load_case(&s, &case).unwrap();
        assert_relative_eq!(
            u[6 * tip],
            w * length * length / (2.0 * E * AREA),
            max_relative = 1e-10
        );
    }
}

#[test]
fn torsion_gives_t_l_over_g_j() {
    let (s, tip) = cantilever(1.3, 2, section(), &Matrix3::identity());
    let mut w = Vector6::zeros();
    w[3] = 500.0;
    let u = solve_load_case(&s, &tip_case(tip, w, &Matrix3::identity())).unwrap();
    assert_relative_eq!(
        u[6 * tip + 3],
        500.0 * 1.3 / (G * TORSION),
        max_relative = 1e-12
    );
}

#[test]
fn timoshenko_shear_adds_p_l_over_g_av() {
    let length = 0.4;
    let (avy, avz) = (1.2e-3, 0.9e-3);
    let mut sec = section();
    sec.shear_area_y = Some(avy);
    sec.shear_area_z = Some(avz);
    for elements in [1, 3] {
        let (s, tip) = cantilever(length, elements, sec, &Matrix3::identity());
        let p = 2000.0;
        let uy = solve_load_case(
            &s,
            &tip_case(
                tip,
                Vector6::new(0.0, p, 0.0, 0.0, 0.0, 0.0),
                &Matrix3::identity(),
            ),
        )
        .unwrap();
        assert_relative_eq!(
            uy[6 * tip + 1],
            p * length.powi(3) / (3.0 * E * IZ) + p * length / (G * avy),
            max_relative = 1e-10
        );
        // Shear does not change the tip rotation under a tip force.
        assert_relative_eq!(
            uy[6 * tip + 5],
            p * length * length / (2.0 * E * IZ),
            max_relative = 1e-10
        );
        let uz = solve_load_case(
            &s,
            &tip_case(
                tip,
                Vector6::new(0.0, 0.0, p, 0.0, 0.0, 0.0),
                &Matrix3::identity(),
            ),
        )
        .unwrap();
        assert_relative_eq!(
            uz[6 * tip + 2],
            p * length.powi(3) / (3.0 * E * IY) + p * length / (G * avz),
            max_relative = 1e-10
        );
    }
}

#[test]
fn l_frame_loaded_out_of_plane() {
    // Arm a along x from the clamp, arm b along y, load P along -z at the end.
    let (a, b, p) = (1.2, 0.8, 900.0);
    let mut s = Structure::new();
    let n0 = s.add_node("clamp", Vector3::zeros()).unwrap();
    let n1 = s.add_node("corner", Vector3::new(a, 0.0, 0.0)).unwrap();
    let n2 = s.add_node("end", Vector3::new(a, b, 0.0)).unwrap();
    s.set_support(n0, [true; 6]).unwrap();
    s.add_beam(beam("arm_a", n0, n1, section(), Vector3::z()))
        .unwrap();
    s.add_beam(beam("arm_b", n1, n2, section(), Vector3::z()))
        .unwrap();
    let mut case = LoadCase::new("out of plane");
    case.nodal_loads
        .push((n2, Vector6::new(0.0, 0.0, -p, 0.0, 0.0, 0.0)));
    let u = solve_load_case(&s, &case).unwrap();
    // Both arms bend about their local y (Iy); arm a also twists under P b.
    let expected = -(p * a.powi(3) / (3.0 * E * IY)
        + p * b.powi(3) / (3.0 * E * IY)
        + p * b * b * a / (G * TORSION));
    assert_relative_eq!(u[6 * n2 + 2], expected, max_relative = 1e-10);
    // Twist of arm a: rotation about x at the corner = -P b a / (G J).
    assert_relative_eq!(
        u[6 * n1 + 3],
        -p * b * a / (G * TORSION),
        max_relative = 1e-10
    );
    // Nothing moves in the plane.
    for d in [0, 1, 5] {
        assert!(u[6 * n2 + d].abs() < 1e-15);
    }
}

/// A portal frame: two columns of height h pinned at the ground, a beam of
/// span l; a horizontal load at the top of the first column.
fn pinned_portal(h: f64, l: f64, column: Section, girder: Section) -> (Structure, [usize; 4]) {
    let mut s = Structure::new();
    let g0 = s.add_node("ground_0", Vector3::zeros()).unwrap();
    let t0 = s.add_node("top_0", Vector3::new(0.0, 0.0, h)).unwrap();
    let t1 = s.add_node("top_1", Vector3::new(l, 0.0, h)).unwrap();
    let g1 = s.add_node("ground_1", Vector3::new(l, 0.0, 0.0)).unwrap();
    // Pinned about y (the frame's bending axis), held otherwise.
    s.set_support(g0, [true, true, true, true, false, true])
        .unwrap();
    s.set_support(g1, [true, true, true, true, false, true])
        .unwrap();
    s.add_beam(beam("column_0", g0, t0, column, Vector3::x()))
        .unwrap();
    s.add_beam(beam("girder", t0, t1, girder, Vector3::z()))
        .unwrap();
    s.add_beam(beam("column_1", t1, g1, column, Vector3::x()))
        .unwrap();
    (s, [g0, t0, t1, g1])
}

#[test]
fn closed_four_bar_portal_frame_sway_equilibrium_and_symmetry() {
    let (h, l, load) = (3.0, 4.0, 10_000.0);
    // Axially stiff members so that the hand formula (bending only) holds.
    let mut column = section();
    column.area = 10.0;
    let mut girder = section();
    girder.area = 10.0;
    girder.iy = 2.0 * IY;
    let (s, [g0, t0, t1, g1]) = pinned_portal(h, l, column, girder);
    let mut case = LoadCase::new("sway");
    case.nodal_loads
        .push((t0, Vector6::new(load, 0.0, 0.0, 0.0, 0.0, 0.0)));
    let f = load_vector(&s, &case).unwrap();
    let u = solve_load_case(&s, &case).unwrap();
    // Bending in the x-z plane uses Iy for columns (local z = global x) and girder.
    let sway = load * h * h / (12.0 * E) * (2.0 * h / column.iy + l / girder.iy);
    assert_relative_eq!(u[6 * t0], sway, max_relative = 1e-6);
    assert_relative_eq!(u[6 * t1], sway, max_relative = 1e-6);
    // Antisymmetry: both top joints rotate alike, base rotations alike.
    assert_relative_eq!(u[6 * t0 + 4], u[6 * t1 + 4], max_relative = 1e-6);
    assert_relative_eq!(u[6 * g0 + 4], u[6 * g1 + 4], max_relative = 1e-6);
    // Equilibrium: reactions balance the load, forces and moments about the origin.
    let r = reactions(&s, &u, &f).unwrap();
    for node in 0..s.node_count() {
        for d in 0..6 {
            if !s.supports()[node][d] {
                assert!(
                    r[6 * node + d].abs() < 1e-8 * load,
                    "residual at node {node} dof {d}"
                );
            }
        }
    }
    let mut force = Vector3::zeros();
    let mut moment = Vector3::zeros();
    for node in [g0, g1] {
        let rf = Vector3::new(r[6 * node], r[6 * node + 1], r[6 * node + 2]);
        let rm = Vector3::new(r[6 * node + 3], r[6 * node + 4], r[6 * node + 5]);
        force += rf;
        moment += rm + s.positions()[node].cross(&rf);
    }
    let applied = Vector3::new(load, 0.0, 0.0);
    assert_relative_eq!(force, -applied, epsilon = 1e-8 * load);
    assert_relative_eq!(
        moment,
        -s.positions()[t0].cross(&applied),
        epsilon = 1e-8 * load * l
    );
    // Each pinned base takes half the shear (antisymmetric frame).
    assert_relative_eq!(r[6 * g0], -load / 2.0, max_relative = 1e-6);
}

#[test]
fn pinned_end_beam_by_release_gives_hinge_stiffness() {
    // Clamped A - B - clamped C, with a hinge (rz released) at B in beam AB:
    // B is carried by two cantilevers, v_B = P L^3 / (6 E Iz).
    let (l, p) = (1.5, 3000.0);
    let mut s = Structure::new();
    let a = s.add_node("A", Vector3::zeros()).unwrap();
    let b = s.add_node("B", Vector3::new(l, 0.0, 0.0)).unwrap();
    let c = s.add_node("C", Vector3::new(2.0 * l, 0.0, 0.0)).unwrap();
    s.set_support(a, [true; 6]).unwrap();
    s.set_support(c, [true; 6]).unwrap();
    let mut ab = beam("AB", a, b, section(), Vector3::z());
    ab.releases[11] = true;
    s.add_beam(ab).unwrap();
    s.add_beam(beam("BC", b, c, section(), Vector3::z()))
        .unwrap();
    let mut case = LoadCase::new("P");
    case.nodal_loads
        .push((b, Vector6::new(0.0, p, 0.0, 0.0, 0.0, 0.0)));
    let u = solve_load_case(&s, &case).unwrap();
    assert_relative_eq!(
        u[6 * b + 1],
        p * l.powi(3) / (6.0 * E * IZ),
        max_relative = 1e-10
    );
    // B's rotation is that of the tip of cantilever BC under P / 2.
    assert_relative_eq!(
        u[6 * b + 5].abs(),
        p / 2.0 * l * l / (2.0 * E * IZ),
        max_relative = 1e-10
    );
    // Without the release: fixed-fixed beam, P (2L)^3 / (192 E I).
    let mut rigid = Structure::new();
    for n in 0..3 {
        rigid.add_node(s.node_name(n), s.positions()[n]).unwrap();
        rigid.set_support(n, s.supports()[n]).unwrap();
    }
    rigid
        .add_beam(beam("AB", a, b, section(), Vector3::z()))
        .unwrap();
    rigid
        .add_beam(beam("BC", b, c, section(), Vector3::z()))
        .unwrap();
    let u = solve_load_case(&rigid, &case).unwrap();
    assert_relative_eq!(
        u[6 * b + 1],
        p * (2.0 * l).powi(3) / (192.0 * E * IZ),
        max_relative = 1e-10
    );
}

#[test]
fn released_own_weight_matches_a_propped_cantilever() {
    // Beam clamped at A, B held in translation but free to turn about z: a
    // propped cantilever, whose pinned end turns by w L^3 / (48 E I) under
    // its own weight.
    let (l, m) = (2.0, 20.0);
    let mut s = Structure::new();
    let a = s.add_node("A", Vector3::zeros()).unwrap();
    let b = s.add_node("B", Vector3::new(l, 0.0, 0.0)).unwrap();
    s.set_support(a, [true; 6]).unwrap();
    s.set_support(b, [true, true, true, true, true, false])
        .unwrap();
    let mut ab = beam("AB", a, b, section(), Vector3::z());
    ab.mass_per_length = m;
    s.add_beam(ab.clone()).unwrap();
    let mut case = LoadCase::new("weight");
    case.gravity = Vector3::new(0.0, -9.81, 0.0);
    let w = m * 9.81;
    let u = solve_load_case(&s, &case).unwrap();
    assert_relative_eq!(
        u[6 * b + 5],
        w * l.powi(3) / (48.0 * E * IZ),
        max_relative = 1e-10
    );

    // Same beam with rz released at B: B's rz is now carried by nothing,
    // a mechanism reported at node B, dof rz.
    let mut released = Structure::new();
    released.add_node("A", Vector3::zeros()).unwrap();
    released.add_node("B", Vector3::new(l, 0.0, 0.0)).unwrap();
    released.set_support(a, [true; 6]).unwrap();
    released
        .set_support(b, [true, true, true, true, true, false])
        .unwrap();
    ab.releases[11] = true;
    released.add_beam(ab).unwrap();
    match solve_load_case(&released, &case) {
        Err(FemError::Singular { node, dof, .. }) => {
            assert_eq!(node, "B");
            assert_eq!(dof, Dof::Rz);
        }
        other => panic!("expected a singular structure, got {other:?}"),
    }
}

/// Rigid-link chain with joints about various axes; all joint stiffnesses
/// huge except Kar.
#[test]
fn condensed_compliance_of_rigid_chain_is_j_diag_inverse_kar_j_transpose() {
    let joint_points = [
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(0.0, 0.0, 0.5),
        Vector3::new(0.6, 0.1, 0.7),
        Vector3::new(1.1, -0.2, 0.9),
    ];
    let axes = [
        Vector3::z(),
        Vector3::y(),
        Vector3::new(1.0, 1.0, 0.0).normalize(),
        Vector3::new(0.2, -0.3, 1.0).normalize(),
    ];
    let kar = [2e6, 1.5e6, 8e5, 5e5];
    let tcp_point = Vector3::new(1.4, 0.1, 0.6);
    let stiff = 1e14;
    let mut rigid = section();
    rigid.area = 1.0;
    rigid.iy = 10.0;
    rigid.iz = 10.0;
    rigid.torsion_constant = 10.0;
    rigid.youngs_modulus = 2e13;
    rigid.shear_modulus = 8e12;

    let mut s = Structure::new();
    let base = s.add_node("base", Vector3::zeros()).unwrap();
    s.set_support(base, [true; 6]).unwrap();
    let mut previous = base;
    for (k, (&point, &axis)) in joint_points.iter().zip(&axes).enumerate() {
        let before = if k == 0 {
            previous
        } else {
            let node = s.add_node(format!("j{k}_in"), point).unwrap();
            s.add_beam(beam(
                &format!("link{k}"),
                previous,
                node,
                rigid,
                perpendicular(point, s.positions()[previous]),
            ))
            .unwrap();
            node
        };
        let after = s.add_node(format!("j{k}_out"), point).unwrap();
        s.add_joint(Joint {
            name: format!("joint{k}"),
            i: before,
            j: after,
            axis,
            local_y: None,
            stiffness: [stiff, stiff, stiff, kar[k], stiff, stiff],
        })
        .unwrap();
        previous = after;
    }
    let tcp = s.add_node("tcp", tcp_point).unwrap();
    s.add_beam(beam(
        "link_tcp",
        previous,
        tcp,
        rigid,
        perpendicular(tcp_point, joint_points[3]),
    ))
    .unwrap();

    let mut fact = Factorization::new(&s, &SolverOptions::condensing_onto(tcp)).unwrap();
    assemble_and_factor(&s, &mut fact).unwrap();
    let c_eq = fact.c_eq().unwrap();
    let mut expected = Matrix6::zeros();
    for k in 0..4 {
        let lin = axes[k].cross(&(tcp_point - joint_points[k]));
        let column = Vector6::new(lin.x, lin.y, lin.z, axes[k].x, axes[k].y, axes[k].z);
        expected += column * column.transpose() / kar[k];
    }
    // Limited by the finite "rigid" stiffnesses and the conditioning they bring.
    assert_relative_eq!(c_eq, expected, epsilon = 1e-5 * expected.amax());
    // K_eq C_eq = I.
    assert_relative_eq!(
        fact.k_eq().unwrap() * c_eq,
        Matrix6::identity(),
        epsilon = 1e-6
    );
}

fn perpendicular(a: Vector3<f64>, b: Vector3<f64>) -> Vector3<f64> {
    let d = a - b;
    let e = if d.x.abs() < d.y.abs().max(d.z.abs()) {
        Vector3::x()
    } else {
        Vector3::y()
    };
    d.cross(&e)
}

#[test]
fn zero_load_gives_zero_displacement() {
    let oblique = Rotation3::from_euler_angles(0.1, 0.2, 0.3).into_inner();
    let (s, _) = cantilever(1.0, 4, section(), &oblique);
    let u = solve_load_case(&s, &LoadCase::new("nothing")).unwrap();
    assert!(u.iter().all(|&x| x == 0.0));
}

#[test]
fn condensation_reproduces_full_solve_at_the_node() {
    // Loads spread over the structure: the condensed model (13), (26) must
    // give the same displacement at the node as the full solve.
    let (mut s, tip) = cantilever(
        2.0,
        5,
        section(),
        &Rotation3::from_euler_angles(0.2, 0.4, -0.3).into_inner(),
    );
    let mid = 2;
    let extra = s
        .add_node("side", s.positions()[mid] + Vector3::new(0.0, 0.0, 0.5))
        .unwrap();
    s.add_beam(beam("side_arm", mid, extra, section(), Vector3::x()))
        .unwrap();
    let mut case = LoadCase::new("spread");
    case.nodal_loads
        .push((mid, Vector6::new(100.0, -50.0, 30.0, 5.0, -2.0, 1.0)));
    case.nodal_loads
        .push((extra, Vector6::new(0.0, 80.0, 0.0, 0.0, 3.0, 0.0)));
    case.nodal_loads
        .push((tip, Vector6::new(-20.0, 10.0, 40.0, 1.0, 0.0, -3.0)));
    let f = load_vector(&s, &case).unwrap();
    let u = solve_load_case(&s, &case).unwrap();
    let mut fact = Factorization::new(&s, &SolverOptions::condensing_onto(tip)).unwrap();
    assemble_and_factor(&s, &mut fact).unwrap();
    let f_eq = fact.f_eq(&f).unwrap();
    let u_tip = fact.c_eq().unwrap() * f_eq;
    assert_relative_eq!(
        u_tip,
        node_displacement(&u, tip),
        max_relative = 1e-9,
        epsilon = 1e-15
    );
    // The same factorization solves the full problem too.
    let u2 = fact.solve(&f).unwrap();
    for (a, b) in u.iter().zip(&u2) {
        assert_relative_eq!(*a, *b, max_relative = 1e-9, epsilon = 1e-15);
    }
}
