#include "kernels/TieConstruction.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace tamp {

TieParticles build_tie_particles(const fem::FemModel& fem, const std::vector<int>& sph_material,
                                 const ParticleSurvey& particles, double dp, double band, int* interface_edges) {
  const fem::FemGrid& grid = fem.grid();
  const int nr = grid.nr(), nz = grid.nz(), ne = fem.mesh().n_elements;
  auto x0 = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), fem.mesh().x0);
  auto conn = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), fem.mesh().conn);

  // 1. The interface: element edges on the boundary of the mesh (no element across) with
  //    particles just beyond them. Local edge k joins nodes k and k + 1 (counter-clockwise:
  //    bottom, right, top, left); the cell across it is (i + di[k], j + dj[k]).
  struct Edge { int a, b; double n_r, n_z; };
  std::vector<Edge> iface;
  std::vector<int> own_edge(ne, -1), own_k(ne, -1);  // the interface edge an element owns
  const int di[4] = {0, 1, 0, -1}, dj[4] = {-1, 0, 1, 0};
  auto active = [&](int i, int j) { return i >= 0 && j >= 0 && i < nr && j < nz && fem.element(i, j) >= 0; };
  // The boundary edges, and a probe half a spacing beyond each: particles there (through
  // the particles' cell list) make it an interface edge.
  struct Candidate { int e, k, a, b; double n_r, n_z; };
  std::vector<Candidate> boundary;
  std::vector<std::array<double, 2>> probe;
  for (int e = 0; e < ne; ++e) {
    const int i = fem.element_i(e), j = fem.element_j(e);
    for (int k = 0; k < 4; ++k) {
      if (active(i + di[k], j + dj[k])) continue;
      const int a = conn(e, k), b = conn(e, (k + 1) % 4);
      const double tr = x0(b, 0) - x0(a, 0), tz = x0(b, 1) - x0(a, 1), len = std::hypot(tr, tz);
      const double n_r = tz / len, n_z = -tr / len;  // outward for counter-clockwise nodes
      boundary.push_back({e, k, a, b, n_r, n_z});
      probe.push_back({0.5 * (x0(a, 0) + x0(b, 0)) + 0.5 * dp * n_r, 0.5 * (x0(a, 1) + x0(b, 1)) + 0.5 * dp * n_z});
    }
  }
  const std::vector<int> beyond = particles.occupied(probe, 0.75 * dp);
  for (size_t c = 0; c < boundary.size(); ++c) {
    if (!beyond[c]) continue;
    const Candidate& E = boundary[c];
    if (own_edge[E.e] >= 0)
      throw std::invalid_argument("tie_fem: element " + std::to_string(E.e) + " has particles beyond two of its edges "
                                  "(a one-element-wide strip or corner of the mesh): not supported");
    own_edge[E.e] = static_cast<int>(iface.size());
    own_k[E.e] = E.k;
    iface.push_back({E.a, E.b, E.n_r, E.n_z});
  }
  if (iface.empty()) throw std::invalid_argument("tie_fem: no element edge has particles beyond it");
  // (The search for the interface distance below is over elements x interface edges: the
  // mesh only, once per model.)
  auto distance_to_interface = [&](double r, double z) {
    double best = 1e300;
    for (const Edge& E : iface) {
      const double ar = x0(E.a, 0), az = x0(E.a, 1), br = x0(E.b, 0) - ar, bz = x0(E.b, 1) - az;
      const double t = std::clamp(((r - ar) * br + (z - az) * bz) / (br * br + bz * bz), 0.0, 1.0);
      best = std::min(best, std::hypot(r - ar - t * br, z - az - t * bz));
    }
    return best;
  };

  // 2. Tie particles: each element within the kernel reach of the interface is sampled at
  //    about the particle spacing; the first row along an interface edge carries its traction.
  std::vector<int> elem, ea, eb, tmat;
  std::vector<double> xi, eta, es, depth, face, nrm_r, nrm_z, pmass, fxi, feta;
  for (int e = 0; e < ne; ++e) {
    const int i = fem.element_i(e), j = fem.element_j(e);
    const double size_r = grid.r[i + 1] - grid.r[i], size_z = grid.z[j + 1] - grid.z[j];
    const int sub_r = std::max(1, static_cast<int>(std::lround(size_r / dp)));
    const int sub_z = std::max(1, static_cast<int>(std::lround(size_z / dp)));
    const double rho0 = fem.materials()[fem.element_material(e)].density;
    for (int b = 0; b < sub_z; ++b)
      for (int a = 0; a < sub_r; ++a) {
        const double p = -1.0 + (2.0 * a + 1.0) / sub_r, q = -1.0 + (2.0 * b + 1.0) / sub_z;
        const double r = grid.r[i] + size_r * 0.5 * (p + 1.0), z = grid.z[j] + size_z * 0.5 * (q + 1.0);
        if (distance_to_interface(r, z) >= band) continue;
        elem.push_back(e);
        xi.push_back(p); eta.push_back(q);
        fxi.push_back(p); feta.push_back(q);
        tmat.push_back(sph_material[fem.element_material(e)]);
        pmass.push_back(rho0 * (size_r / sub_r) * (size_z / sub_z));
        const int k = own_k[e];
        // first row next to the element's interface edge k; s runs from node k to node k + 1
        const bool first = k == 0 ? b == 0 : k == 1 ? a == sub_r - 1 : k == 2 ? b == sub_z - 1 : k == 3 ? a == 0 : false;
        if (!first) {
          ea.push_back(conn(e, 0)); eb.push_back(conn(e, 0)); es.push_back(0.0);
          depth.push_back(0.0); face.push_back(0.0); nrm_r.push_back(0.0); nrm_z.push_back(0.0);
          continue;
        }
        const Edge& E = iface[own_edge[e]];
        // The first row moves with its interface edge (the nodes that receive its traction):
        // following the element's interior point instead left the edge nodes' motion half
        // unseen, and a tie at the axis grew unstable at ~50 1/s (docs/coupling.md).
        if (k == 0) feta.back() = -1.0;
        else if (k == 1) fxi.back() = 1.0;
        else if (k == 2) feta.back() = 1.0;
        else fxi.back() = -1.0;
        const double s = k == 0 ? 0.5 * (p + 1) : k == 1 ? 0.5 * (q + 1) : k == 2 ? 0.5 * (1 - p) : 0.5 * (1 - q);
        const double d = 1.0 / (k == 0 || k == 2 ? sub_r : sub_z);  // segment as a fraction of the edge
        const double len = std::hypot(x0(E.b, 0) - x0(E.a, 0), x0(E.b, 1) - x0(E.a, 1));
        // Weight of node b: the tie particle stands for a constant traction over its segment
        // [s - d/2, s + d/2] of the edge, handed on with the consistent ring weights
        // Int N_b 2 pi r ds / Int 2 pi r ds (Simpson: exact, r linear along the edge). On an
        // edge z = const next to the axis this differs much from s: with one tie particle
        // per element, s gave the axis node 50 % too much force.
        const double s0 = s - 0.5 * d, s1 = s + 0.5 * d;
        auto r_at = [&](double t) { return x0(E.a, 0) + t * (x0(E.b, 0) - x0(E.a, 0)); };
        const double num = s0 * r_at(s0) + 4 * s * r_at(s) + s1 * r_at(s1);
        const double den = r_at(s0) + 4 * r_at(s) + r_at(s1);
        ea.push_back(E.a); eb.push_back(E.b); es.push_back(den > 0 ? num / den : s);

        const double dist = (x0(E.a, 0) - r) * E.n_r + (x0(E.a, 1) - z) * E.n_z;  // to the edge's line
        depth.push_back(dist);
        face.push_back(2.0 * pi * (r + dist * E.n_r) * len * d);  // ring area of the segment
        nrm_r.push_back(E.n_r); nrm_z.push_back(E.n_z);
      }
  }
  const int n = static_cast<int>(elem.size());
  auto upload = [](const char* label, const auto& host) {  // host vector -> device view
    View1<typename std::decay_t<decltype(host)>::value_type> v(std::string(label), host.size());
    auto h = Kokkos::create_mirror_view(v);
    for (size_t k = 0; k < host.size(); ++k) h(k) = host[k];
    Kokkos::deep_copy(v, h);
    return v;
  };
  auto upload2 = [](const char* label, const std::vector<double>& c0, const std::vector<double>& c1) {
    ViewN<double, 2> v(std::string(label), c0.size());
    auto h = Kokkos::create_mirror_view(v);
    for (size_t k = 0; k < c0.size(); ++k) { h(k, 0) = c0[k]; h(k, 1) = c1[k]; }
    Kokkos::deep_copy(v, h);
    return v;
  };
  TieParticles tie;
  tie.count = n;
  tie.material = upload("tamp::tie::material", tmat);
  tie.element = upload("tamp::tie::element", elem);
  tie.depth = upload("tamp::tie::depth", depth);
  tie.face_area = upload("tamp::tie::face_area", face);
  tie.planar_mass = upload("tamp::tie::planar_mass", pmass);
  tie.normal = upload2("tamp::tie::normal", nrm_r, nrm_z);
  tie.parent = upload2("tamp::tie::parent", xi, eta);
  tie.follow = upload2("tamp::tie::follow", fxi, feta);
  tie.force = ViewN<double, 2>("tamp::tie::force", n);
  {  // the hand-over to the edge nodes (ea, eb, share es for eb), by node in tie order
    std::map<int, std::vector<std::pair<int, double>>> by_node;
    for (int k = 0; k < n; ++k) {
      by_node[ea[k]].emplace_back(k, 1.0 - es[k]);
      by_node[eb[k]].emplace_back(k, es[k]);
    }
    std::vector<int> node_id, node_start{0}, node_tie;
    std::vector<double> node_share;
    for (const auto& [node, terms] : by_node) {
      node_id.push_back(node);
      for (const auto& [k, w] : terms) { node_tie.push_back(k); node_share.push_back(w); }
      node_start.push_back(static_cast<int>(node_tie.size()));
    }
    tie.node_count = static_cast<int>(node_id.size());
    tie.node_id = upload("tamp::tie::node_id", node_id);
    tie.node_start = upload("tamp::tie::node_start", node_start);
    tie.node_tie = upload("tamp::tie::node_tie", node_tie);
    tie.node_share = upload("tamp::tie::node_share", node_share);
  }
  if (interface_edges) *interface_edges = static_cast<int>(iface.size());
  return tie;
}

}  // namespace tamp
