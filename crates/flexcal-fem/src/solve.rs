//! Assembly (21), supports (22), Cholesky solve (23) and static condensation
//! (24)-(27) on a profile (skyline) matrix.
//!
//! The supported stiffness matrix is stored row by row from each row's first
//! non-zero column to the diagonal (its envelope), after a reverse
//! Cuthill-McKee ordering of the nodes. A Cholesky factorization never fills
//! outside the envelope, so a chain of 11 nodes costs the same as a banded
//! solve and a 1 000-DOF frame stays sparse. When a condensation node is
//! requested it is numbered last: eliminating every other equation leaves
//! exactly K_eq of (27) in the trailing 6 x 6 block, which is captured and
//! then factored in turn.

use nalgebra::{Matrix6, Vector3, Vector6};

use crate::element::{Matrix12, beam_weight_loads, element_matrix};
use crate::error::{Dof, FemError, Result};
use crate::structure::{ElementId, LoadCase, NodeId, Structure};

/// Options of a [`Factorization`].
#[derive(Debug, Clone, PartialEq)]
pub struct SolverOptions {
    /// A Cholesky pivot smaller than `pivot_tolerance` times the original
    /// diagonal entry of its equation declares the structure singular
    /// (default 1e-12; range (0, 1)). The paper's 1e-10 N.m/rad passive
    /// joints next to 1e15 N/m penalty stiffnesses stay well above it inside
    /// closed loops; an open chain with such a joint is reported as a
    /// mechanism, which it numerically is.
    pub pivot_tolerance: f64,
    /// Node onto which to condense (K_eq, F_eq of (27)); `None` for none.
    pub condense_onto: Option<NodeId>,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            pivot_tolerance: 1e-12,
            condense_onto: None,
        }
    }
}

impl SolverOptions {
    /// The default options with condensation onto `node`.
    pub fn condensing_onto(node: NodeId) -> Self {
        Self {
            condense_onto: Some(node),
            ..Self::default()
        }
    }
}

/// Sentinel equation number of a supported degree of freedom.
const FIXED: usize = usize::MAX;

/// What a factorization was built for: node count, element connectivity and
/// supports. Positions and values may change; these may not.
#[derive(Debug, Clone, PartialEq)]
struct Topology {
    supports: Vec<[bool; 6]>,
    connections: Vec<(NodeId, NodeId)>,
}

impl Topology {
    fn of(structure: &Structure) -> Self {
        Self {
            supports: structure.supports().to_vec(),
            connections: structure
                .elements()
                .map(|e| structure.element_nodes(e))
                .collect(),
        }
    }
}

/// The Cholesky factorization of a structure's supported stiffness matrix,
/// with its preallocated storage: the per-thread workspace of the solver.
///
/// Build it once per topology with [`Factorization::new`] (ordering and
/// storage), then call [`assemble_and_factor`] for every configuration (no
/// allocation). It then solves any number of right-hand sides and, when built
/// with a condensation node, gives K_eq, C_eq and F_eq of (24)-(27).
#[derive(Debug, Clone)]
pub struct Factorization {
    topology: Topology,
    options: SolverOptions,
    node_names: Vec<String>,
    /// Equation number of each global DOF (`6 * node + dof`), or [`FIXED`].
    equation_of_dof: Vec<usize>,
    /// Global DOF of each equation.
    dof_of_equation: Vec<usize>,
    /// First stored column of each row.
    first: Vec<usize>,
    /// Offset of each row's first stored entry in `values` (one more entry
    /// at the end: the total size).
    start: Vec<usize>,
    /// K, then L (lower triangle, row-wise envelope).
    values: Vec<f64>,
    /// Diagonal of K before factorization (pivot test).
    diagonal: Vec<f64>,
    /// Equations before the condensed block (all of them without one).
    retained: usize,
    k_eq: Matrix6<f64>,
    factored: bool,
    scratch: Vec<f64>,
    /// 1 / L_jj of the factored rows: a multiplication is much cheaper
    /// than a division in the innermost loop.
    inverse_pivots: Vec<f64>,
}

impl Factorization {
    /// Orders the equations and allocates the storage for `structure`'s
    /// topology. Fails if the condensation node is out of range or supported.
    pub fn new(structure: &Structure, options: &SolverOptions) -> Result<Self> {
        let node_count = structure.node_count();
        if !(options.pivot_tolerance > 0.0 && options.pivot_tolerance < 1.0) {
            return Err(crate::error::invalid(
                "solver options",
                "pivot_tolerance",
                format!("must lie in (0, 1), got {}", options.pivot_tolerance),
            ));
        }
        if let Some(node) = options.condense_onto {
            structure.check_node("condensation node", node)?;
            if let Some(d) = (0..6).find(|&d| structure.supports()[node][d]) {
                return Err(FemError::CondensedNodeSupported {
                    node: structure.node_name(node).to_string(),
                    dof: Dof::from_index(d),
                });
            }
        }
        let topology = Topology::of(structure);
        let mut adjacency: Vec<Vec<NodeId>> = vec![Vec::new(); node_count];
        for &(i, j) in &topology.connections {
            if !adjacency[i].contains(&j) {
                adjacency[i].push(j);
                adjacency[j].push(i);
            }
        }
        let mut order = reverse_cuthill_mckee(&adjacency);
        if let Some(node) = options.condense_onto {
            order.retain(|&n| n != node);
            order.push(node);
        }

        let mut equation_of_dof = vec![FIXED; 6 * node_count];
        let mut dof_of_equation = Vec::with_capacity(6 * node_count);
        let mut first_equation_of_node = vec![FIXED; node_count];
        for &node in &order {
            for d in 0..6 {
                if !structure.supports()[node][d] {
                    if first_equation_of_node[node] == FIXED {
                        first_equation_of_node[node] = dof_of_equation.len();
                    }
                    equation_of_dof[6 * node + d] = dof_of_equation.len();
                    dof_of_equation.push(6 * node + d);
                }
            }
        }
        let n = dof_of_equation.len();
        let mut first = vec![0; n];
        for node in 0..node_count {
            let own = first_equation_of_node[node];
            if own == FIXED {
                continue;
            }
            let reach = adjacency[node]
                .iter()
                .map(|&m| first_equation_of_node[m])
                .fold(own, usize::min);
            for d in 0..6 {
                let e = equation_of_dof[6 * node + d];
                if e != FIXED {
                    first[e] = reach;
                }
            }
        }
        let mut start = Vec::with_capacity(n + 1);
        let mut total = 0;
        for (e, &f) in first.iter().enumerate() {
            start.push(total);
            total += e - f + 1;
        }
        start.push(total);
        let retained = if options.condense_onto.is_some() {
            n - 6
        } else {
            n
        };
        Ok(Self {
            topology,
            options: options.clone(),
            node_names: structure.node_names().to_vec(),
            equation_of_dof,
            dof_of_equation,
            first,
            start,
            values: vec![0.0; total],
            diagonal: vec![0.0; n],
            retained,
            k_eq: Matrix6::zeros(),
            factored: false,
            scratch: vec![0.0; n],
            inverse_pivots: vec![0.0; n],
        })
    }

    /// Number of equations (free degrees of freedom).
    pub fn equation_count(&self) -> usize {
        self.dof_of_equation.len()
    }

    /// Number of stored entries of the profile (memory and work indicator).
    pub fn profile_size(&self) -> usize {
        self.values.len()
    }

    /// Equation number of global DOF `6 * node + dof`, `None` if supported.
    pub fn equation(&self, node: NodeId, dof: Dof) -> Option<usize> {
        let e = *self.equation_of_dof.get(6 * node + dof.index())?;
        (e != FIXED).then_some(e)
    }

    /// Node and degree of freedom of equation `equation`.
    pub fn dof_of_equation(&self, equation: usize) -> (NodeId, Dof) {
        let g = self.dof_of_equation[equation];
        (g / 6, Dof::from_index(g))
    }

    /// Whether [`assemble_and_factor`] has succeeded since the last change.
    pub fn is_factored(&self) -> bool {
        self.factored
    }

    /// The condensation node, if any.
    pub fn condensed_node(&self) -> Option<NodeId> {
        self.options.condense_onto
    }

    fn index(&self, row: usize, column: usize) -> usize {
        debug_assert!(column <= row && column >= self.first[row]);
        self.start[row] + column - self.first[row]
    }

    fn check_topology(&self, structure: &Structure) -> Result<()> {
        if self.topology.supports.len() != structure.node_count() {
            return Err(FemError::TopologyChanged {
                message: format!(
                    "{} nodes instead of {}",
                    structure.node_count(),
                    self.topology.supports.len()
                ),
            });
        }
        if self.topology.supports != structure.supports() {
            return Err(FemError::TopologyChanged {
                message: "supports differ".to_string(),
            });
        }
        let same = self.topology.connections.len() == structure.elements().count()
            && structure
                .elements()
                .zip(&self.topology.connections)
                .all(|(e, &c)| structure.element_nodes(e) == c);
        if !same {
            return Err(FemError::TopologyChanged {
                message: "elements or their nodes differ".to_string(),
            });
        }
        Ok(())
    }

    /// Adds an element matrix into the profile (supported rows and columns
    /// dropped: equation (22)).
    fn scatter(&mut self, nodes: [NodeId; 2], k: &Matrix12) {
        let mut equations = [FIXED; 12];
        for (a, e) in equations.iter_mut().enumerate() {
            *e = self.equation_of_dof[6 * nodes[a / 6] + a % 6];
        }
        for (a, &ea) in equations.iter().enumerate() {
            if ea == FIXED {
                continue;
            }
            let row = self.start[ea] - self.first[ea];
            for (b, &eb) in equations.iter().enumerate() {
                if eb <= ea {
                    debug_assert!(eb >= self.first[ea]);
                    self.values[row + eb] += k[(a, b)];
                }
            }
        }
    }

    /// Assembles the supported global stiffness K_C (equations (21)-(22))
    /// into the profile, without factoring it.
    fn assemble(&mut self, structure: &Structure) -> Result<()> {
        self.check_topology(structure)?;
        self.factored = false;
        self.values.fill(0.0);
        for element in structure.elements() {
            let m = element_matrix(structure, element)?;
            self.scatter(m.nodes, &m.stiffness);
        }
        for e in 0..self.equation_count() {
            self.diagonal[e] = self.values[self.index(e, e)];
        }
        Ok(())
    }

    fn singular(&self, equation: usize, pivot: f64) -> FemError {
        let (node, dof) = self.dof_of_equation(equation);
        let ratio = if self.diagonal[equation] != 0.0 {
            pivot / self.diagonal[equation]
        } else {
            0.0
        };
        FemError::Singular {
            node: self.node_names[node].clone(),
            dof,
            pivot_ratio: ratio,
        }
    }

    fn take_pivot(&self, equation: usize, pivot: f64) -> Result<f64> {
        let threshold = self.options.pivot_tolerance * self.diagonal[equation].abs();
        if pivot.is_finite() && pivot > threshold && pivot > 0.0 {
            Ok(pivot.sqrt())
        } else {
            Err(self.singular(equation, pivot))
        }
    }

    /// Row-oriented (Crout) Cholesky inside the envelope. Rows of the
    /// condensed block are only reduced by the retained equations; their
    /// Schur complement is K_eq.
    fn factor(&mut self) -> Result<()> {
        let n = self.equation_count();
        let retained = self.retained;
        for i in 0..n {
            let fi = self.first[i];
            let (head, tail) = self.values.split_at_mut(self.start[i]);
            let row_i = &mut tail[..i - fi + 1];
            for j in fi..i.min(retained) {
                let fj = self.first[j];
                let k0 = fi.max(fj);
                let row_j = &head[self.start[j]..self.start[j] + j - fj + 1];
                let s = row_i[j - fi] - dot(&row_i[k0 - fi..j - fi], &row_j[k0 - fj..j - fj]);
                row_i[j - fi] = s * self.inverse_pivots[j];
            }
            if i < retained {
                let d = row_i[i - fi] - dot(&row_i[..i - fi], &row_i[..i - fi]);
                let threshold = self.options.pivot_tolerance * self.diagonal[i].abs();
                if !(d.is_finite() && d > threshold && d > 0.0) {
                    return Err(self.singular(i, d));
                }
                let root = d.sqrt();
                row_i[i - fi] = root;
                self.inverse_pivots[i] = 1.0 / root;
            } else {
                for j in retained.max(fi)..=i {
                    let fj = self.first[j];
                    let k0 = fi.max(fj);
                    let update = if k0 >= retained {
                        0.0
                    } else if j == i {
                        dot(
                            &row_i[k0 - fi..retained - fi],
                            &row_i[k0 - fi..retained - fi],
                        )
                    } else {
                        let row_j = &head[self.start[j]..];
                        dot(
                            &row_i[k0 - fi..retained - fi],
                            &row_j[k0 - fj..retained - fj],
                        )
                    };
                    row_i[j - fi] -= update;
                }
            }
        }
        if retained < n {
            for a in 0..6 {
                for b in 0..=a {
                    let v = self.values[self.index(retained + a, retained + b)];
                    self.k_eq[(a, b)] = v;
                    self.k_eq[(b, a)] = v;
                }
            }
            // Cholesky of K_eq itself, completing L; a failure here means
            // the structure is singular at the condensation node.
            for i in retained..n {
                for j in retained..i {
                    let mut s = self.values[self.index(i, j)];
                    for k in retained..j {
                        s -= self.values[self.index(i, k)] * self.values[self.index(j, k)];
                    }
                    let at = self.index(i, j);
                    self.values[at] = s / self.values[self.index(j, j)];
                }
                let mut d = self.values[self.index(i, i)];
                for k in retained..i {
                    let l = self.values[self.index(i, k)];
                    d -= l * l;
                }
                let root = self.take_pivot(i, d)?;
                let at = self.index(i, i);
                self.values[at] = root;
            }
        }
        self.factored = true;
        Ok(())
    }

    fn require_factored(&self) -> Result<()> {
        if self.factored {
            Ok(())
        } else {
            Err(FemError::NotAvailable(
                "the factorization has not been computed (call assemble_and_factor)",
            ))
        }
    }

    fn check_global(&self, what: &'static str, len: usize) -> Result<()> {
        let expected = self.equation_of_dof.len();
        if len == expected {
            Ok(())
        } else {
            Err(FemError::LengthMismatch {
                what,
                expected,
                found: len,
            })
        }
    }

    /// Forward substitution L y = b over equations `0..rows` (in place).
    fn forward(&self, x: &mut [f64], rows: usize) {
        for i in 0..rows {
            let fi = self.first[i];
            let row = &self.values[self.start[i]..self.start[i + 1]];
            x[i] = (x[i] - dot(&row[..i - fi], &x[fi..i])) / row[i - fi];
        }
    }

    /// Back substitution L^T x = y (in place).
    fn backward(&self, x: &mut [f64]) {
        for i in (0..self.equation_count()).rev() {
            let fi = self.first[i];
            let row = &self.values[self.start[i]..self.start[i + 1]];
            x[i] /= row[i - fi];
            let xi = x[i];
            for (xk, l) in x[fi..i].iter_mut().zip(&row[..i - fi]) {
                *xk -= l * xi;
            }
        }
    }

    /// Solves K_C u = f (equation (23)) for a load vector in global layout
    /// (`6 * node + dof`, N and N.m); writes displacements in the same layout
    /// (m and rad), zero on supported DOFs. Loads on supported DOFs go to the
    /// supports and are ignored.
    pub fn solve_into(&mut self, loads: &[f64], displacements: &mut [f64]) -> Result<()> {
        self.require_factored()?;
        self.check_global("loads", loads.len())?;
        self.check_global("displacements", displacements.len())?;
        let mut x = std::mem::take(&mut self.scratch);
        for (e, &g) in self.dof_of_equation.iter().enumerate() {
            x[e] = loads[g];
        }
        self.forward(&mut x, self.equation_count());
        self.backward(&mut x);
        displacements.fill(0.0);
        for (e, &g) in self.dof_of_equation.iter().enumerate() {
            displacements[g] = x[e];
        }
        self.scratch = x;
        Ok(())
    }

    /// Allocating twin of [`Factorization::solve_into`].
    pub fn solve(&mut self, loads: &[f64]) -> Result<Vec<f64>> {
        let mut u = vec![0.0; self.equation_of_dof.len()];
        self.solve_into(loads, &mut u)?;
        Ok(u)
    }

    fn require_condensed(&self) -> Result<()> {
        self.require_factored()?;
        if self.options.condense_onto.is_none() {
            return Err(FemError::NotAvailable(
                "no condensation node was given in the solver options",
            ));
        }
        Ok(())
    }

    /// Equivalent stiffness at the condensation node, K_eq of (27)
    /// [N/m, N/rad; N.m/m, N.m/rad], global axes, `[linear; angular]`.
    pub fn k_eq(&self) -> Result<Matrix6<f64>> {
        self.require_condensed()?;
        Ok(self.k_eq)
    }

    /// Equivalent compliance C_eq = K_eq^{-1} of (13), obtained by solving
    /// with the Cholesky factor of K_eq (never an explicit inverse).
    pub fn c_eq(&self) -> Result<Matrix6<f64>> {
        self.require_condensed()?;
        let r = self.retained;
        let l = |a: usize, b: usize| self.values[self.index(r + a, r + b)];
        let mut c = Matrix6::zeros();
        for column in 0..6 {
            let mut x = [0.0; 6];
            x[column] = 1.0;
            for i in 0..6 {
                let s: f64 = (0..i).map(|k| l(i, k) * x[k]).sum();
                x[i] = (x[i] - s) / l(i, i);
            }
            for i in (0..6).rev() {
                let s: f64 = (i + 1..6).map(|k| l(k, i) * x[k]).sum();
                x[i] = (x[i] - s) / l(i, i);
            }
            for i in 0..6 {
                c[(i, column)] = x[i];
            }
        }
        Ok((c + c.transpose()) * 0.5)
    }

    /// Equivalent wrench at the condensation node, F_eq = F_E - K_ER K_RR^{-1} F_R
    /// of (27), for a load vector in global layout (N, N.m).
    pub fn f_eq(&mut self, loads: &[f64]) -> Result<Vector6<f64>> {
        self.require_condensed()?;
        self.check_global("loads", loads.len())?;
        let r = self.retained;
        let mut x = std::mem::take(&mut self.scratch);
        for (e, &g) in self.dof_of_equation.iter().enumerate() {
            x[e] = loads[g];
        }
        self.forward(&mut x, r);
        let mut f = Vector6::zeros();
        for a in 0..6 {
            let i = r + a;
            let fi = self.first[i];
            let row = &self.values[self.start[i]..self.start[i + 1]];
            let reach = r.max(fi);
            f[a] = x[i] - dot(&row[..reach - fi], &x[fi..reach]);
        }
        self.scratch = x;
        Ok(f)
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    // Four independent accumulators let the compiler vectorise the loop.
    let mut acc = [0.0; 4];
    let chunks = a.len() / 4;
    for c in 0..chunks {
        for k in 0..4 {
            acc[k] += a[4 * c + k] * b[4 * c + k];
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for k in 4 * chunks..a.len() {
        s += a[k] * b[k];
    }
    s
}

/// Reverse Cuthill-McKee ordering of the nodes, component by component,
/// each started from a pseudo-peripheral node.
fn reverse_cuthill_mckee(adjacency: &[Vec<NodeId>]) -> Vec<NodeId> {
    let n = adjacency.len();
    let degree = |v: NodeId| adjacency[v].len();
    let mut visited = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let bfs_last_level = |start: NodeId| -> (Vec<NodeId>, NodeId) {
        let mut seen = vec![false; n];
        let mut level = vec![start];
        seen[start] = true;
        let mut all = vec![start];
        loop {
            let mut next = Vec::new();
            for &v in &level {
                for &w in &adjacency[v] {
                    if !seen[w] {
                        seen[w] = true;
                        next.push(w);
                    }
                }
            }
            if next.is_empty() {
                let far = *level.iter().min_by_key(|&&v| degree(v)).unwrap_or(&start);
                return (all, far);
            }
            all.extend(&next);
            level = next;
        }
    };
    while let Some(seed) = (0..n).filter(|&v| !visited[v]).min_by_key(|&v| degree(v)) {
        let (_, start) = bfs_last_level(seed);
        let mut queue = std::collections::VecDeque::from([start]);
        visited[start] = true;
        while let Some(v) = queue.pop_front() {
            order.push(v);
            let mut next: Vec<NodeId> = adjacency[v]
                .iter()
                .copied()
                .filter(|&w| !visited[w])
                .collect();
            next.sort_by_key(|&w| degree(w));
            for w in next {
                visited[w] = true;
                queue.push_back(w);
            }
        }
    }
    order.reverse();
    order
}

/// Assembles K_C for the current node positions and element values and
/// factors it (equations (21)-(23)); with a condensation node, also captures
/// K_eq of (27). Allocation-free.
pub fn assemble_and_factor(structure: &Structure, factorization: &mut Factorization) -> Result<()> {
    factorization.assemble(structure)?;
    factorization.factor()
}

/// Global load vector (`6 * node + dof`, N and N.m) of a load case: nodal
/// wrenches plus consistent own-weight loads.
pub fn load_vector(structure: &Structure, case: &LoadCase) -> Result<Vec<f64>> {
    let mut f = vec![0.0; structure.dof_count()];
    load_vector_into(structure, case, &mut f)?;
    Ok(f)
}

/// Writes the load vector of `case` into `loads` (length `6 * nodes`).
pub fn load_vector_into(structure: &Structure, case: &LoadCase, loads: &mut [f64]) -> Result<()> {
    if loads.len() != structure.dof_count() {
        return Err(FemError::LengthMismatch {
            what: "loads",
            expected: structure.dof_count(),
            found: loads.len(),
        });
    }
    structure.check_load_case(case)?;
    loads.fill(0.0);
    for (node, wrench) in &case.nodal_loads {
        for d in 0..6 {
            loads[6 * node + d] += wrench[d];
        }
    }
    add_weight_loads(structure, &case.gravity, loads)
}

fn add_weight_loads(
    structure: &Structure,
    gravity: &Vector3<f64>,
    loads: &mut [f64],
) -> Result<()> {
    for (b, beam) in structure.beams().iter().enumerate() {
        if beam.mass_per_length == 0.0 {
            continue;
        }
        let f = beam_weight_loads(structure, b, gravity)?;
        for a in 0..12 {
            let node = if a < 6 { beam.i } else { beam.j };
            loads[6 * node + a % 6] += f[a];
        }
    }
    Ok(())
}

/// The full (unsupported) global stiffness matrix K_G of (21), dense,
/// `6n x 6n`. For inspection and tests; solving goes through
/// [`Factorization`].
pub fn global_stiffness_dense(structure: &Structure) -> Result<nalgebra::DMatrix<f64>> {
    let n = structure.dof_count();
    let mut k = nalgebra::DMatrix::zeros(n, n);
    for element in structure.elements() {
        let m = element_matrix(structure, element)?;
        for a in 0..12 {
            for b in 0..12 {
                k[(m.global_dof(a), m.global_dof(b))] += m.stiffness[(a, b)];
            }
        }
    }
    Ok(k)
}

/// `K_G u - f` in global layout (N, N.m): on supported DOFs, the reaction
/// (force and moment the support exerts on the structure); on free DOFs, the
/// equilibrium residual (zero up to round-off).
pub fn reactions(structure: &Structure, displacements: &[f64], loads: &[f64]) -> Result<Vec<f64>> {
    let n = structure.dof_count();
    for (what, len) in [
        ("displacements", displacements.len()),
        ("loads", loads.len()),
    ] {
        if len != n {
            return Err(FemError::LengthMismatch {
                what,
                expected: n,
                found: len,
            });
        }
    }
    let mut r: Vec<f64> = loads.iter().map(|f| -f).collect();
    for element in structure.elements() {
        let m = element_matrix(structure, element)?;
        for a in 0..12 {
            let mut s = 0.0;
            for b in 0..12 {
                s += m.stiffness[(a, b)] * displacements[m.global_dof(b)];
            }
            r[m.global_dof(a)] += s;
        }
    }
    Ok(r)
}

/// Displacements of one load case, solved from scratch (allocating
/// convenience over [`Factorization`]).
pub fn solve_load_case(structure: &Structure, case: &LoadCase) -> Result<Vec<f64>> {
    let mut factorization = Factorization::new(structure, &SolverOptions::default())?;
    assemble_and_factor(structure, &mut factorization)?;
    factorization.solve(&load_vector(structure, case)?)
}

/// Sensitivity of the displacements to one joint stiffness value:
/// du/dk = -K^{-1} (dK/dk) u, with `u` the displacements (global layout) of
/// the factored structure and `component` in the order of
/// [`crate::Joint::stiffness`].
pub fn joint_stiffness_sensitivity(
    structure: &Structure,
    factorization: &mut Factorization,
    joint: usize,
    component: usize,
    displacements: &[f64],
) -> Result<Vec<f64>> {
    if joint >= structure.joints().len() {
        return Err(FemError::IndexOutOfRange {
            owner: "joint_stiffness_sensitivity".to_string(),
            kind: "joint",
            index: joint,
            count: structure.joints().len(),
        });
    }
    factorization.check_global("displacements", displacements.len())?;
    let dk = crate::element::joint_stiffness_derivative(structure, joint, component)?;
    let (i, j) = structure.element_nodes(ElementId::Joint(joint));
    let nodes = [i, j];
    let mut rhs = vec![0.0; structure.dof_count()];
    for a in 0..12 {
        let ga = 6 * nodes[a / 6] + a % 6;
        for b in 0..12 {
            rhs[ga] -= dk[(a, b)] * displacements[6 * nodes[b / 6] + b % 6];
        }
    }
    factorization.solve(&rhs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reverse_cuthill_mckee_is_a_permutation_covering_every_component() {
        // Two components: a path 0-1-2-3 and a pair 4-5, plus an isolated 6.
        let adjacency = vec![
            vec![1],
            vec![0, 2],
            vec![1, 3],
            vec![2],
            vec![5],
            vec![4],
            vec![],
        ];
        let mut order = reverse_cuthill_mckee(&adjacency);
        assert_eq!(order.len(), 7);
        // Along the path, neighbours stay neighbours in the order.
        let position = |v: usize, order: &[usize]| order.iter().position(|&w| w == v).unwrap();
        for (a, b) in [(0, 1), (1, 2), (2, 3)] {
            let gap = position(a, &order).abs_diff(position(b, &order));
            assert_eq!(gap, 1, "{order:?}");
        }
        order.sort_unstable();
        assert_eq!(order, (0..7).collect::<Vec<_>>());
    }

    #[test]
    fn dot_matches_the_plain_sum_for_every_length() {
        for n in 0..11 {
            let a: Vec<f64> = (0..n).map(|k| k as f64 * 0.5 - 1.0).collect();
            let b: Vec<f64> = (0..n).map(|k| 2.0 - k as f64).collect();
            let plain: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
            assert!((dot(&a, &b) - plain).abs() < 1e-12);
        }
    }

    #[test]
    fn pivot_tolerance_outside_its_range_is_rejected() {
        let s = Structure::new();
        for tolerance in [0.0, 1.0, f64::NAN, -1e-3] {
            let options = SolverOptions {
                pivot_tolerance: tolerance,
                condense_onto: None,
            };
            assert!(matches!(
                Factorization::new(&s, &options),
                Err(FemError::InvalidValue { .. })
            ));
        }
    }

    #[test]
    fn using_a_factorization_before_factoring_or_on_another_topology_fails() {
        let mut s = Structure::new();
        let a = s.add_node("a", Vector3::zeros()).unwrap();
        let b = s.add_node("b", Vector3::x()).unwrap();
        s.set_support(a, [true; 6]).unwrap();
        s.add_spring(crate::Spring {
            name: "k".into(),
            i: a,
            j: b,
            k: 1.0,
        })
        .unwrap();
        let mut fact = Factorization::new(&s, &SolverOptions::default()).unwrap();
        assert!(matches!(
            fact.solve(&[0.0; 12]),
            Err(FemError::NotAvailable(_))
        ));
        assert!(matches!(fact.k_eq(), Err(FemError::NotAvailable(_))));
        s.set_support(b, [false, true, true, true, true, true])
            .unwrap();
        assert!(matches!(
            assemble_and_factor(&s, &mut fact),
            Err(FemError::TopologyChanged { .. })
        ));
        let mut fact = Factorization::new(&s, &SolverOptions::default()).unwrap();
        assemble_and_factor(&s, &mut fact).unwrap();
        let u = fact.solve(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(u.unwrap()[6], 3.0);
        assert!(matches!(
            fact.solve(&[0.0; 5]),
            Err(FemError::LengthMismatch { .. })
        ));
    }
}
