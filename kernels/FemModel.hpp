// The element model: the axisymmetric quad FEM (kernels/FemQuad.hpp): a structured
// mesh on a grid of node lines r_i, z_j (graded or not) whose cells each hold an element
// of one material or are left empty (where particles are, for an SPH-FEM tie), nodal
// boundary conditions, and central-difference stepping. Header-only. docs/fem.md.
#pragma once
#include <cmath>
#include <stdexcept>
#include <utility>
#include <string>
#include <vector>

#include "kernels/BoundaryLoads.hpp"
#include "kernels/DeterministicSum.hpp"
#include "kernels/FemQuad.hpp"
#include "kernels/Geostatic.hpp"

namespace tamp::fem {

struct FemBlock {
  double r0 = 0, r1 = 1, z0 = 0, z1 = 1;  // m
  int nr = 1, nz = 1;                     // elements along r and z
};

// A structured grid of node lines; cell (i, j) lies between r[i], r[i+1] and z[j], z[j+1].
// material[j * nr + i] is the cell's material (an index into the model's material list) or
// -1 for no element. Nodes keep their grid number j * (nr + 1) + i; nodes of no element are
// inert (fixed, unit mass) so that the kernels need no special case.
struct FemGrid {
  std::vector<double> r, z;   // m, strictly increasing
  std::vector<int> material;  // per cell, -1 = empty
  int nr() const { return static_cast<int>(r.size()) - 1; }
  int nz() const { return static_cast<int>(z.size()) - 1; }
  // A uniform block of one material (index 0).
  static FemGrid uniform(const FemBlock& b) {
    FemGrid g;
    for (int i = 0; i <= b.nr; ++i) g.r.push_back(b.r0 + (b.r1 - b.r0) * i / b.nr);
    for (int j = 0; j <= b.nz; ++j) g.z.push_back(b.z0 + (b.z1 - b.z0) * j / b.nz);
    g.material.assign(static_cast<size_t>(b.nr) * b.nz, 0);
    return g;
  }
};

// Nodal force assembly: a ScatterView duplicated per thread on host back ends (atomic on
// GPUs), or atomic additions on every back end. perf/bench_fem.cpp measures both.
enum FemAssembly : int { ASSEMBLY_SCATTER = 0, ASSEMBLY_ATOMIC = 1 };

struct FemOptions {
  double cfl = 0.8;                      // dt = cfl * min_e L_e / c_e (1.0 ran stable)
  int hourglass = HOURGLASS_VISCOUS;     // HourglassForm; the deck's default too ([fem] hourglass)
  double hourglass_coefficient = 0.1;    // kappa (docs/fem.md)
  double gravity = 0.0;                  // m/s2, acting in -z
  double damping = 0.0;                  // 1/s, mass-proportional (dynamic relaxation)
  bool axis_symmetry = true;             // r0 == 0: the axis nodes get v_r = 0
  int assembly = ASSEMBLY_SCATTER;       // nodal force assembly (FemAssembly)
};

// Boundary condition of a block side. Roller: the normal velocity is zero. Velocity: both
// components prescribed (vr, vz).
enum class FemSide { Inner, Outer, Bottom, Top };  // r = r0, r = r1, z = z0, z = z1
enum class FemBc { Free, Fixed, Roller, Velocity };

struct FemEnergies {
  double kinetic = 0;    // J, from the half-step velocities
  double internal = 0;   // J, work of the stresses
  double hourglass = 0;  // J, work of the hourglass forces
  // Work done on the nodes since the start (FemMesh::node_work), J:
  double boundary_work = 0;  // by the non-reflecting boundary (< 0: radiated)
  double damping_work = 0;   // by the mass damping (<= 0)
  double tie_work = 0;       // by the particles through the tie
};

// Energies of the elements of one material, J.
struct FemMaterialEnergy {
  double internal = 0;   // work of the stresses
  double hourglass = 0;  // work of the hourglass forces
  double elastic = 0;    // elastic strain energy of the current stress (MaterialParams::elastic_energy_density)
};

class FemModel {
 public:
  FemModel(const MaterialParams& material, const FemBlock& block, const FemOptions& options = {})
      : FemModel(std::vector<MaterialParams>{material}, checked_uniform(block), options) {}

  FemModel(const std::vector<MaterialParams>& materials, const FemGrid& grid, const FemOptions& options = {})
      : grid_(grid), opt_(options), materials_host_(materials) {
    const int nr = grid.nr(), nz = grid.nz();
    if (nr < 1 || nz < 1 || grid.material.size() != static_cast<size_t>(nr) * nz || grid.r.front() < 0)
      throw std::invalid_argument("FemModel: bad grid (node lines, cell materials or r < 0)");
    for (int i = 0; i < nr; ++i)
      if (!(grid.r[i + 1] > grid.r[i])) throw std::invalid_argument("FemModel: r lines not increasing");
    for (int j = 0; j < nz; ++j)
      if (!(grid.z[j + 1] > grid.z[j])) throw std::invalid_argument("FemModel: z lines not increasing");
    block_ = FemBlock{grid.r.front(), grid.r.back(), grid.z.front(), grid.z.back(), nr, nz};
    cell_element_.assign(grid.material.size(), -1);
    for (int j = 0; j < nz; ++j)
      for (int i = 0; i < nr; ++i) {
        const int m = grid.material[j * nr + i];
        if (m < -1 || m >= static_cast<int>(materials.size()))
          throw std::invalid_argument("FemModel: cell material " + std::to_string(m) + " not in the material list");
        if (m < 0) continue;
        cell_element_[j * nr + i] = static_cast<int>(element_cell_.size());
        element_cell_.push_back(j * nr + i);
      }
    const int nn = (nr + 1) * (nz + 1), ne = static_cast<int>(element_cell_.size());
    if (ne == 0) throw std::invalid_argument("FemModel: the grid has no element");
    mesh_.n_nodes = nn;
    mesh_.n_elements = ne;
    mesh_.x = ViewN<double, 2>("fem::x", nn);
    mesh_.x0 = ViewN<double, 2>("fem::x0", nn);
    mesh_.v = ViewN<double, 2>("fem::v", nn);
    mesh_.f_int = ViewN<double, 2>("fem::f_int", nn);
    mesh_.f_ext = ViewN<double, 2>("fem::f_ext", nn);
    mesh_.f_tie = ViewN<double, 2>("fem::f_tie", nn);
    mesh_.v_bc = ViewN<double, 2>("fem::v_bc", nn);
    mesh_.mass = View1<double>("fem::mass", nn);
    mesh_.bc = View1<int>("fem::bc", nn);
    mesh_.dashpot = ViewN<double, 2>("fem::dashpot", nn);
    mesh_.spring = ViewN<double, 2>("fem::spring", nn);
    mesh_.f_hold = ViewN<double, 2>("fem::f_hold", nn);
    mesh_.node_work = ViewN<double, 3>("fem::node_work", nn);
    mesh_.conn = Kokkos::View<int* [4], MemSpace>("fem::conn", ne);
    mesh_.material = View1<int>("fem::material", ne);
    mesh_.stress = ViewN<double, 4>("fem::stress", ne);
    mesh_.strain_rate = ViewN<double, 4>("fem::strain_rate", ne);
    mesh_.plastic_strain = View1<double>("fem::plastic_strain", ne);
    mesh_.compaction = View1<double>("fem::compaction", ne);
    mesh_.history = ViewN<double, kHistorySlots>("fem::history", ne);
    mesh_.elem_mass = View1<double>("fem::elem_mass", ne);
    mesh_.volume = View1<double>("fem::volume", ne);
    mesh_.hourglass_force = ViewN<double, 2>("fem::hourglass_force", ne);
    mesh_.internal_energy = View1<double>("fem::internal_energy", ne);
    mesh_.hourglass_energy = View1<double>("fem::hourglass_energy", ne);
    mesh_.materials = Kokkos::View<MaterialParams*, MemSpace>("fem::materials", materials.size());
    auto mat_h = Kokkos::create_mirror_view(mesh_.materials);
    for (size_t k = 0; k < materials.size(); ++k) mat_h(k) = materials[k];
    Kokkos::deep_copy(mesh_.materials, mat_h);

    auto conn_h = Kokkos::create_mirror_view(mesh_.conn);
    auto emat_h = Kokkos::create_mirror_view(mesh_.material);
    node_used_.assign(nn, 0);
    for (int e = 0; e < ne; ++e) {
      const int i = element_cell_[e] % nr, j = element_cell_[e] / nr;
      conn_h(e, 0) = node(i, j);
      conn_h(e, 1) = node(i + 1, j);
      conn_h(e, 2) = node(i + 1, j + 1);
      conn_h(e, 3) = node(i, j + 1);
      emat_h(e) = grid.material[element_cell_[e]];
      for (int k = 0; k < 4; ++k) node_used_[conn_h(e, k)] = 1;
    }
    Kokkos::deep_copy(mesh_.conn, conn_h);
    Kokkos::deep_copy(mesh_.material, emat_h);

    std::vector<double> r(nn), z(nn);
    for (int j = 0; j <= nz; ++j)
      for (int i = 0; i <= nr; ++i) {
        r[node(i, j)] = grid.r[i];
        z[node(i, j)] = grid.z[j];
      }
    set_node_positions(r, z);
    for (int n = 0; n < nn; ++n)
      if (!node_used_[n]) set_node_bc(n, BC_R | BC_Z);
    if (block_.r0 == 0 && opt_.axis_symmetry) set_side(FemSide::Inner, FemBc::Roller);
    scatter_ = Kokkos::Experimental::create_scatter_view(mesh_.f_int);
    atomic_scatter_ = Kokkos::Experimental::create_scatter_view(
        Kokkos::Experimental::ScatterSum{}, Kokkos::Experimental::ScatterNonDuplicated{},
        Kokkos::Experimental::ScatterAtomic{}, mesh_.f_int);
  }

  int node(int i, int j) const { return j * (block_.nr + 1) + i; }
  // The k-th node along a side (k = 0 .. side_edges(side)), from the axis or the base up.
  int side_node(FemSide side, int k) const {
    switch (side) {
      case FemSide::Inner: return node(0, k);
      case FemSide::Outer: return node(block_.nr, k);
      case FemSide::Bottom: return node(k, 0);
      default: return node(k, block_.nz);
    }
  }
  // The element along the k-th edge of a side (-1: none there).
  int side_element(FemSide side, int k) const {
    switch (side) {
      case FemSide::Inner: return element(0, k);
      case FemSide::Outer: return element(block_.nr - 1, k);
      case FemSide::Bottom: return element(k, 0);
      default: return element(k, block_.nz - 1);
    }
  }
  int side_edges(FemSide side) const {
    return side == FemSide::Inner || side == FemSide::Outer ? block_.nz : block_.nr;
  }
  // The element of cell (i, j), or -1 where the cell is empty.
  int element(int i, int j) const { return cell_element_[j * block_.nr + i]; }
  // Grid cell (i, j) of element e.
  int element_i(int e) const { return element_cell_[e] % block_.nr; }
  int element_j(int e) const { return element_cell_[e] / block_.nr; }
  // Material of element e (index into materials()).
  int element_material(int e) const { return grid_.material[element_cell_[e]]; }
  bool node_used(int n) const { return node_used_[n] != 0; }
  const FemBlock& block() const { return block_; }  // the grid's bounding box and cell counts
  const FemGrid& grid() const { return grid_; }
  const std::vector<MaterialParams>& materials() const { return materials_host_; }
  const FemOptions& options() const { return opt_; }
  FemMesh& mesh() { return mesh_; }
  const FemMesh& mesh() const { return mesh_; }
  double time() const { return time_; }
  long steps() const { return steps_; }
  double last_dt() const { return dt_prev_; }
  // The step the next call of step() takes: cfl * min_e L_e / c_e.
  double stable_dt() {
    if (!(stable_dt_ > 0)) compute_forces(0.0);
    return opt_.cfl * stable_dt_;
  }

  // Moves the nodes (e.g. to a distorted mesh) and makes this the reference configuration:
  // the lumped masses and the element masses are recomputed; state is not touched.
  void set_node_positions(const std::vector<double>& r, const std::vector<double>& z) {
    const int nn = mesh_.n_nodes, ne = mesh_.n_elements;
    if ((int)r.size() != nn || (int)z.size() != nn)
      throw std::invalid_argument("FemModel::set_node_positions: size");
    auto x_h = Kokkos::create_mirror_view(mesh_.x);
    for (int i = 0; i < nn; ++i) { x_h(i, 0) = r[i]; x_h(i, 1) = z[i]; }
    auto conn_h = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh_.conn);
    auto mass_h = Kokkos::create_mirror_view(mesh_.mass);
    auto emass_h = Kokkos::create_mirror_view(mesh_.elem_mass);
    Kokkos::deep_copy(mass_h, 0.0);
    for (int e = 0; e < ne; ++e) {
      double re[4], ze[4], w[4];
      for (int k = 0; k < 4; ++k) { re[k] = r[conn_h(e, k)]; ze[k] = z[conn_h(e, k)]; }
      QuadGeometry g;
      if (!quad_geometry(re, ze, g))
        throw std::invalid_argument("FemModel: element " + std::to_string(e) + " is inverted");
      const double rho = materials_host_[element_material(e)].density;
      emass_h(e) = rho * g.volume;
      quad_mass_weights(re, ze, w);
      for (int k = 0; k < 4; ++k) mass_h(conn_h(e, k)) += rho * w[k];
    }
    for (int i = 0; i < nn; ++i)
      if (!(mass_h(i) > 0)) mass_h(i) = 1.0;  // a node of no element (inert, fixed)
    Kokkos::deep_copy(mesh_.x, x_h);
    Kokkos::deep_copy(mesh_.x0, x_h);
    Kokkos::deep_copy(mesh_.mass, mass_h);
    Kokkos::deep_copy(mesh_.elem_mass, emass_h);
    stable_dt_ = 0;  // geometry changed: forces and step recomputed on demand
    forces_valid_ = false;
  }

  // Boundary conditions. Flags accumulate (a corner on a roller side and a fixed side is
  // fixed); a later prescribed value overwrites an earlier one.
  void set_node_bc(int n, int flags, double vr = 0, double vz = 0) {
    auto bc_h = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh_.bc);
    auto vbc_h = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh_.v_bc);
    apply_bc(bc_h, vbc_h, n, flags, vr, vz);
    Kokkos::deep_copy(mesh_.bc, bc_h);
    Kokkos::deep_copy(mesh_.v_bc, vbc_h);
  }
  void set_side(FemSide side, FemBc type, double vr = 0, double vz = 0) {
    auto bc_h = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh_.bc);
    auto vbc_h = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh_.v_bc);
    const bool r_side = (side == FemSide::Inner || side == FemSide::Outer);
    int flags = BC_NONE;
    switch (type) {
      case FemBc::Free: flags = BC_NONE; break;
      case FemBc::Fixed: flags = BC_R | BC_Z; vr = vz = 0; break;
      case FemBc::Roller: flags = r_side ? BC_R : BC_Z; vr = vz = 0; break;
      case FemBc::Velocity: flags = BC_R | BC_Z; break;
    }
    for (int k = 0; k <= side_edges(side); ++k) apply_bc(bc_h, vbc_h, side_node(side, k), flags, vr, vz);
    Kokkos::deep_copy(mesh_.bc, bc_h);
    Kokkos::deep_copy(mesh_.v_bc, vbc_h);
  }

  // Makes a side a non-reflecting viscous-spring boundary (as for particles, docs/sph.md):
  // each node gets, over its tributary ring area A = Int N_I 2 pi r ds of the side,
  // dashpots rho c_p A (normal) and rho c_s A (tangential) (Lysmer & Kuhlemeyer 1969) and
  // springs K_n A, K_t A with K_n = 4G/(3R), K_t = 2G/(3R) (Deeks & Randolph 1994, Liu et
  // al. 2006); R = spring_distance (m, 0: no springs). The held static force is set by
  // hold_boundary_forces(). Uses the material's initial density.
  void set_non_reflecting(FemSide side, double spring_distance) {
    if (spring_distance < 0) throw std::invalid_argument("FemModel::set_non_reflecting: spring_distance < 0");
    auto x_h = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh_.x0);
    auto c_h = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh_.dashpot);
    auto k_h = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh_.spring);
    const bool r_side = (side == FemSide::Inner || side == FemSide::Outer);
    const int nrm = r_side ? 0 : 1, tan = 1 - nrm;
    for (int k = 0; k < side_edges(side); ++k) {
      const int e = side_element(side, k);
      if (e < 0) continue;  // no element along this piece of the side
      const MaterialParams& m = materials_host_[element_material(e)];
      const ViscousSpring vs = viscous_spring(m, m.density, spring_distance);  // kernels/BoundaryLoads.hpp
      const int a = side_node(side, k), b = side_node(side, k + 1);
      const double ra = x_h(a, 0), rb = x_h(b, 0);
      const double len = std::hypot(x_h(b, 0) - ra, x_h(b, 1) - x_h(a, 1));
      // Int N_a 2 pi r ds over a straight edge with r linear: 2 pi L (2 r_a + r_b) / 6
      const double Aa = 2.0 * pi * len * (2.0 * ra + rb) / 6.0, Ab = 2.0 * pi * len * (ra + 2.0 * rb) / 6.0;
      for (const auto& [n, A] : {std::pair<int, double>{a, Aa}, std::pair<int, double>{b, Ab}}) {
        c_h(n, nrm) += vs.dashpot_n * A;
        c_h(n, tan) += vs.dashpot_t * A;
        k_h(n, nrm) += vs.spring_n * A;
        k_h(n, tan) += vs.spring_t * A;
      }
    }
    Kokkos::deep_copy(mesh_.dashpot, c_h);
    Kokkos::deep_copy(mesh_.spring, k_h);
  }

  // Holds, on the non-reflecting boundary nodes, the force that keeps them in equilibrium
  // now (f_int + m g e_z): a geostatic state keeps its support while waves pass out.
  void hold_boundary_forces() {
    if (!forces_valid_) compute_forces(0.0);
    auto f = mesh_.f_int; auto c = mesh_.dashpot; auto m = mesh_.mass; auto fh = mesh_.f_hold;
    const double g = opt_.gravity;
    Kokkos::parallel_for("tamp::fem::hold", Kokkos::RangePolicy<ExecSpace>(0, mesh_.n_nodes), KOKKOS_LAMBDA(int i) {
      const bool on = c(i, 0) > 0 || c(i, 1) > 0;
      fh(i, 0) = on ? f(i, 0) : 0.0;
      fh(i, 1) = on ? f(i, 1) + m(i) * g : 0.0;
    });
  }

  // Initial state setters (host vectors indexed by node / element).
  void set_velocities(const std::vector<double>& vr, const std::vector<double>& vz) {
    auto v_h = Kokkos::create_mirror_view(mesh_.v);
    for (int i = 0; i < mesh_.n_nodes; ++i) { v_h(i, 0) = vr.at(i); v_h(i, 1) = vz.at(i); }
    Kokkos::deep_copy(mesh_.v, v_h);
  }
  void set_uniform_stress(const double s[4]) {
    auto s_h = Kokkos::create_mirror_view(mesh_.stress);
    for (int e = 0; e < mesh_.n_elements; ++e)
      for (int c = 0; c < 4; ++c) s_h(e, c) = s[c];
    Kokkos::deep_copy(mesh_.stress, s_h);
    forces_valid_ = false;
  }

  // Stress of every element (host vector, 4 components rr, zz, tt, rz per element, Pa).
  // The at-rest stress of the layers at every element's centre (kernels/Geostatic.hpp).
  void set_geostatic_stress(const GeostaticLayers<>& layers, double k0) {
    Kokkos::parallel_for("tamp::fem::geostatic_stress", Kokkos::RangePolicy<ExecSpace>(0, mesh_.n_elements),
                         ElementGeostaticStress{mesh_.x0, mesh_.conn, mesh_.material, mesh_.materials, mesh_.stress,
                                                layers, k0});
    forces_valid_ = false;
  }


  // Clock of a restored state (checkpoints): the time, steps and the last step; the forces
  // are recomputed from the restored stresses and positions before the next step.
  void restore_clock(double time, long steps, double last_dt) {
    time_ = time; steps_ = steps; dt_prev_ = last_dt;
    forces_valid_ = false;
    stable_dt_ = 0;
  }

  // Mass-proportional damping (1/s) and gravity (m/s2) from the next step on.
  void set_damping(double d) { opt_.damping = d; }
  void set_gravity(double g) { opt_.gravity = g; }

  // Element pass alone: the strain increment of the current velocities over dt (dt = 0:
  // none), the stress update, and the assembled internal forces at the current positions.
  void compute_forces(double dt) { element_pass(dt, 0.0); }

  // One central-difference step; dt <= 0 takes the stable step.
  void step(double dt = 0) {
    if (!(dt > 0)) {
      if (!forces_valid_) compute_forces(0.0);
      dt = opt_.cfl * stable_dt_;
    }
    move_nodes(dt);
    update_elements(dt);
  }

  // The two halves of step(), for a driver that interleaves them with the particles (the
  // SPH-FEM tie): move_nodes kicks v^{n-1/2} -> v^{n+1/2} with the forces of x^n and moves
  // x^n -> x^{n+1}; update_elements updates the stresses and the internal forces at x^{n+1}
  // and advances the clock.
  void move_nodes(double dt) {
    if (!forces_valid_) compute_forces(0.0);
    QuadNodeUpdate upd;
    upd.x = mesh_.x; upd.x0 = mesh_.x0; upd.v = mesh_.v; upd.f_int = mesh_.f_int; upd.f_ext = mesh_.f_ext;
    upd.f_tie = mesh_.f_tie;
    upd.dashpot = mesh_.dashpot; upd.spring = mesh_.spring; upd.f_hold = mesh_.f_hold;
    upd.node_work = mesh_.node_work;
    upd.v_bc = mesh_.v_bc; upd.mass = mesh_.mass; upd.bc = mesh_.bc;
    upd.gravity = opt_.gravity;
    upd.damping = opt_.damping;
    upd.dt_kick = 0.5 * (dt_prev_ + dt);
    upd.dt = dt;
    Kokkos::parallel_for("tamp::fem::nodes", Kokkos::RangePolicy<ExecSpace>(0, mesh_.n_nodes), upd);
    dt_kick_ = upd.dt_kick;
  }
  void update_elements(double dt) {
    element_pass(dt, dt_kick_);
    dt_prev_ = dt;
    time_ += dt;
    ++steps_;
  }

  void advance_to(double t_end) {
    while (time_ < t_end) {
      const double dt = opt_.cfl * stable_dt();
      step(time_ + dt > t_end ? t_end - time_ : dt);
    }
  }

  FemEnergies energies() const { return energy_sums(mesh_); }

  // Sums in a fixed order (kernels/DeterministicSum.hpp): the same on any thread count, so
  // that an energy account read at a stage's end restarts bit for bit.
  static FemEnergies energy_sums(const FemMesh& mesh) {
    auto v = mesh.v; auto m = mesh.mass; auto w = mesh.node_work;
    auto ui = mesh.internal_energy; auto uh = mesh.hourglass_energy;
    FemEnergies e;
    const auto nodes = fixed_order_sum<4>("tamp::fem::node_energies", mesh.n_nodes, KOKKOS_LAMBDA(int i, double* s) {
      s[0] += 0.5 * m(i) * (v(i, 0) * v(i, 0) + v(i, 1) * v(i, 1));
      s[1] += w(i, 0);
      s[2] += w(i, 1);
      s[3] += w(i, 2);
    });
    const auto elements = fixed_order_sum<2>("tamp::fem::element_energies", mesh.n_elements, KOKKOS_LAMBDA(int k, double* s) {
      s[0] += ui(k);
      s[1] += uh(k);
    });
    e.kinetic = nodes[0];
    e.boundary_work = nodes[1];
    e.damping_work = nodes[2];
    e.tie_work = nodes[3];
    e.internal = elements[0];
    e.hourglass = elements[1];
    return e;
  }
  // Gravitational energy of the nodes, sum m g z (z from the mesh's origin), J.
  double potential_energy(double gravity) const {
    auto x = mesh_.x; auto m = mesh_.mass;
    return fixed_order_sum<1>("tamp::fem::potential", mesh_.n_nodes,
                              KOKKOS_LAMBDA(int i, double* s) { s[0] += m(i) * gravity * x(i, 1); })[0];
  }
  // Per mesh material: the stress work, the hourglass work and the elastic energy.
  std::vector<FemMaterialEnergy> material_energies() const {
    const int nm = static_cast<int>(materials_host_.size());
    auto mat = mesh_.material; auto mats = mesh_.materials; auto st = mesh_.stress; auto vol = mesh_.volume;
    auto ui = mesh_.internal_energy; auto uh = mesh_.hourglass_energy;
    const std::vector<double> s = fixed_order_sums("tamp::fem::material_energies", mesh_.n_elements, 3 * nm,
        KOKKOS_LAMBDA(int k, double* sum) {
          const int j = 3 * mat(k);
          sum[j] += ui(k);
          sum[j + 1] += uh(k);
          sum[j + 2] += vol(k) * mats(mat(k)).elastic_energy_density(st(k, 0), st(k, 1), st(k, 2), st(k, 3));
        });
    std::vector<FemMaterialEnergy> out(nm);
    for (int j = 0; j < nm; ++j) out[j] = {s[3 * j], s[3 * j + 1], s[3 * j + 2]};
    return out;
  }

  // One element pass (stress update over dt, then the internal forces) with the constitutive
  // models of the list Models (models/ModelList.hpp); the steps run it with RegisteredModels,
  // and a test runs a model of its own through it (tests/test_toy_model.cpp).
  template <class Models = RegisteredModels>
  void element_pass_with(double dt, double dt_kick) {
    if (opt_.assembly == ASSEMBLY_ATOMIC) {
      run_element_pass<Models>(atomic_scatter_, dt, dt_kick);
    } else {
      run_element_pass<Models>(scatter_, dt, dt_kick);
    }
  }

 private:
  void element_pass(double dt, double dt_kick) { element_pass_with<RegisteredModels>(dt, dt_kick); }

  template <class Models, class Scatter>
  void run_element_pass(Scatter& scatter, double dt, double dt_kick) {
    QuadElementPassT<Scatter, Models> pass;
    pass.x = mesh_.x; pass.v = mesh_.v; pass.conn = mesh_.conn;
    pass.material = mesh_.material; pass.materials = mesh_.materials;
    pass.stress = mesh_.stress; pass.strain_rate = mesh_.strain_rate;
    pass.plastic_strain = mesh_.plastic_strain; pass.compaction = mesh_.compaction; pass.history = mesh_.history;
    pass.elem_mass = mesh_.elem_mass;
    pass.volume = mesh_.volume; pass.internal_energy = mesh_.internal_energy;
    pass.hourglass_energy = mesh_.hourglass_energy;
    pass.hourglass_force = mesh_.hourglass_force;
    pass.f_scatter = scatter;
    pass.dt = dt;
    pass.dt_kick = dt_kick;
    pass.hourglass_form = opt_.hourglass;
    pass.hourglass_coef = opt_.hourglass_coefficient;
    Kokkos::deep_copy(mesh_.f_int, 0.0);
    scatter.reset();
    double dt_min = 1e300;
    Kokkos::parallel_reduce("tamp::fem::elements",
                            Kokkos::RangePolicy<ExecSpace>(0, mesh_.n_elements), pass,
                            Kokkos::Min<double>(dt_min));
    Kokkos::Experimental::contribute(mesh_.f_int, scatter);
    if (!(dt_min > 0))
      throw std::runtime_error("FemModel: inverted or degenerate element at t = " +
                               std::to_string(time_));
    stable_dt_ = dt_min;
    forces_valid_ = true;
  }

  template <class B, class V>
  static void apply_bc(B& bc_h, V& vbc_h, int n, int flags, double vr, double vz) {
    bc_h(n) |= flags;
    if (flags & BC_R) vbc_h(n, 0) = vr;
    if (flags & BC_Z) vbc_h(n, 1) = vz;
  }

  static FemGrid checked_uniform(const FemBlock& b) {
    if (b.nr < 1 || b.nz < 1 || !(b.r1 > b.r0) || !(b.z1 > b.z0) || b.r0 < 0)
      throw std::invalid_argument("FemModel: bad block");
    return FemGrid::uniform(b);
  }

  FemGrid grid_;
  FemBlock block_;
  FemOptions opt_;
  std::vector<MaterialParams> materials_host_;
  std::vector<int> cell_element_, element_cell_;  // cell -> element (-1: empty), element -> cell
  std::vector<char> node_used_;
  FemMesh mesh_;
  ForceScatter scatter_;
  AtomicForceScatter atomic_scatter_;
  double time_ = 0, dt_prev_ = 0, stable_dt_ = 0, dt_kick_ = 0;
  long steps_ = 0;
  bool forces_valid_ = false;
};

}  // namespace tamp::fem
