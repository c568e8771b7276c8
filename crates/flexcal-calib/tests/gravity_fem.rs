//! The elasto-geometric model's gravity deflection against flexcal's frame
//! finite elements: a UR10 built of stiff beams and joint springs (equations
//! (16)-(23)), loaded by the link weights and the payload, deflects its TCP
//! as the calibration model predicts (joint springs, rigid links, first
//! order in the deflection).

use flexcal_calib::{ErrorModel, GravityCompliance, JointTerms, Measurement, MeasurementSet};
use flexcal_fem::{
    Beam, Factorization, Joint, LoadCase, NodeId, Section, SolverOptions, Structure,
    assemble_and_factor, load_vector,
};
use flexcal_kinematics::{Data, RobotDescription, forward_frames};
use nalgebra::{Isometry3, Point3, Vector3, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Links much stiffer than the joints (rigid for this comparison).
fn stiff_section() -> Section {
    Section {
        youngs_modulus: 1e13,
        shear_modulus: 4e12,
        area: 1e-2,
        iy: 1e-5,
        iz: 1e-5,
        torsion_constant: 2e-5,
        shear_area_y: None,
        shear_area_z: None,
    }
}

/// Connects `from` to a node at `position` on the same rigid link (a stiff
/// beam, or the node itself when the points coincide).
fn rigid_point(s: &mut Structure, from: NodeId, position: Vector3<f64>, name: &str) -> NodeId {
    let origin = s.positions()[from];
    if (position - origin).norm() < 1e-9 {
        return from;
    }
    let node = s.add_node(name, position).unwrap();
    let axis = position - origin;
    let helper = if axis.cross(&Vector3::z()).norm() > 1e-6 * axis.norm() {
        Vector3::z()
    } else {
        Vector3::x()
    };
    s.add_beam(Beam {
        name: format!("link to {name}"),
        i: from,
        j: node,
        section: stiff_section(),
        vecxz: helper,
        releases: [false; 12],
        mass_per_length: 0.0,
    })
    .unwrap();
    node
}

#[test]
fn gravity_deflection_matches_a_frame_model_with_joint_springs() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let mut gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    gravity.payload_mass = 1.5;
    gravity.payload_center = Vector3::new(0.02, -0.01, 0.12);
    let compliance: [f64; 6] = [0.0, 12e-6, 9e-6, 20e-6, 15e-6, 10e-6];
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut data = Data::new(&model);
    for _ in 0..5 {
        let q: Vec<f64> = (0..6).map(|_| rng.random_range(-2.5..2.5)).collect();
        forward_frames(&model, &mut data, &q, model.nominal_params()).unwrap();
        let frame = |name: &str| data.frame_pose(model.frame_index(name).unwrap()).unwrap();

        // Frame model: base node clamped, one joint spring per axis between
        // the node of the previous link and the node of the next, stiff
        // beams along the links, a node at every centre of mass.
        let mut s = Structure::new();
        let first = frame("1").translation.vector;
        let base = s.add_node("base", first).unwrap();
        s.set_support(base, [true; 6]).unwrap();
        let mut previous = base;
        let mut link_nodes = Vec::new();
        for (i, name) in ["1", "2", "3", "4", "5", "6"].iter().enumerate() {
            let pose = frame(name);
            let o = pose.translation.vector;
            let on_previous = rigid_point(&mut s, previous, o, &format!("before joint {name}"));
            let after = s.add_node(format!("joint {name}"), o).unwrap();
            let axis = pose.rotation * Vector3::z();
            s.add_joint(Joint {
                name: format!("joint {name}"),
                i: on_previous,
                j: after,
                axis,
                local_y: None,
                // Rigid but for the rotation about the axis (joint 1 carries
                // no gravity torque: any stiffness will do for it).
                stiffness: [1e10, 1e10, 1e10, 1.0 / compliance[i].max(1e-9), 1e10, 1e10],
            })
            .unwrap();
            previous = after;
            link_nodes.push(after);
        }
        let mut case = LoadCase::new("gravity");
        for m in &gravity.masses {
            let k = model.frame_index(&m.frame).unwrap();
            let link = link_nodes[["1", "2", "3", "4", "5", "6"]
                .iter()
                .position(|n| *n == m.frame)
                .unwrap()];
            let com = data.frame_pose(k).unwrap() * Point3::from(m.center);
            let node = rigid_point(&mut s, link, com.coords, &m.name);
            let f = gravity.gravity * m.mass;
            case.nodal_loads
                .push((node, Vector6::new(f.x, f.y, f.z, 0.0, 0.0, 0.0)));
        }
        let tcp_pose = frame("6");
        let payload_point = tcp_pose * Point3::from(gravity.payload_center);
        let payload = rigid_point(&mut s, previous, payload_point.coords, "payload");
        let f = gravity.gravity * gravity.payload_mass;
        case.nodal_loads
            .push((payload, Vector6::new(f.x, f.y, f.z, 0.0, 0.0, 0.0)));
        let mut factorization = Factorization::new(&s, &SolverOptions::default()).unwrap();
        assemble_and_factor(&s, &mut factorization).unwrap();
        let u = factorization
            .solve(&load_vector(&s, &case).unwrap())
            .unwrap();
        let tcp = previous;
        let fe = Vector3::new(u[6 * tcp], u[6 * tcp + 1], u[6 * tcp + 2]);

        // The calibration model: the same robot at q + C tau, seen in R0.
        let set = MeasurementSet::new(
            "one pose",
            vec![Measurement::new(q.clone(), Vector3::zeros())],
        )
        .unwrap();
        let problem = ErrorModel::one_target(
            &model,
            &set,
            false,
            Isometry3::identity(),
            Isometry3::identity(),
        )
        .unwrap()
        .with_elastic(Some(&gravity), &JointTerms::default())
        .unwrap();
        let eo = problem.elastic_offset().unwrap();
        let mut x = problem.initial_unknowns();
        x[eo..eo + 6].copy_from_slice(&compliance);
        x[eo + 6] = gravity.payload_mass;
        let moment = gravity.payload_center * gravity.payload_mass;
        x[eo + 7..eo + 10].copy_from_slice(moment.as_slice());
        let loaded = problem.predict(&x).unwrap()[0].translation.vector;
        let rigid = tcp_pose.translation.vector;
        let model_deflection = loaded - rigid;
        assert!(
            fe.norm() > 1e-4,
            "a deflection of tenths of a millimetre is expected, got {fe:?}"
        );
        // Equal to first order: the remainder is second order in the
        // deflection angles (about 1e-3 rad) and the links' own compliance.
        assert!(
            (fe - model_deflection).norm() < 0.02 * fe.norm() + 2e-6,
            "q = {q:?}: frame model {fe:?}, calibration model {model_deflection:?}"
        );
    }
}
