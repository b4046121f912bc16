// Results output: particle snapshots as HDF5, an XDMF index that ParaView opens as a time
// series, and CSV tables. All of it runs on the host; callers copy device data first.
//
// Snapshot layout (one file per output time):
//   /particles                 group, attributes step (int64), time (float64, s)
//   /particles/<field>         1-D datasets of length n, each with a string attribute "units":
//                              r, z, v_r, v_z, density, s_rr, s_zz, s_tt, s_rz, plastic_strain,
//                              internal_energy, mass (float64), material (int32)
//   /particles/coordinates     n x 3 float64 (r, z, 0), the XDMF geometry
//   /elements                  only with tied finite elements ([fem]): node_r, node_z,
//                              coordinates (nodes x 3), connectivity (elements x 4, int32,
//                              counter-clockwise), and per element s_rr, s_zz, s_tt, s_rz,
//                              plastic_strain (float64), material (int32)
//
// Errors (file cannot be created/opened, dataset missing, inconsistent sizes) throw
// std::runtime_error naming the file (std::invalid_argument for bad arguments).
#pragma once
#include <cstddef>
#include <map>
#include <string>
#include <vector>

namespace tamp {

struct ElementSnapshot {              // host copies of the tied FEM mesh (empty without one)
  std::vector<double> node_r, node_z; // m, current node positions
  std::vector<int> connectivity;      // 4 node ids per element, counter-clockwise
  std::vector<double> s_rr, s_zz, s_tt, s_rz;  // Pa, tension positive
  std::vector<double> plastic_strain; // -
  std::vector<int> material;          // index into Config::materials
  std::size_t size() const { return s_rr.size(); }
  std::size_t nodes() const { return node_r.size(); }
};

struct ParticleSnapshot {             // host copies of the fields of the real particles
  long step = 0;
  double time = 0;                    // s
  std::vector<double> r, z;           // m
  std::vector<double> v_r, v_z;       // m/s
  std::vector<double> density;        // kg/m3
  std::vector<double> s_rr, s_zz, s_tt, s_rz;  // Pa, tension positive
  std::vector<double> plastic_strain; // accumulated equivalent plastic strain, -
  std::vector<double> internal_energy;// specific, J/kg
  std::vector<double> mass;           // kg
  std::vector<int> material;          // index into Config::materials
  ElementSnapshot elements;           // the tied elements, if any

  std::size_t size() const { return r.size(); }
  void resize(std::size_t n);         // every field to n entries
};

// Writes `s` to `path` (created or replaced; written to "<path>.tmp" and renamed, so a
// reader never sees a half-written file). Every field must have s.size() entries.
void write_snapshot_h5(const std::string& path, const ParticleSnapshot& s);

// Reads a file written by write_snapshot_h5 (for tests and restarts).
ParticleSnapshot read_snapshot_h5(const std::string& path);

// An XDMF file listing snapshots as a temporal collection of Polyvertex grids, with one
// scalar Attribute per field. write() rewrites the whole file (atomically), so calling it
// after every add() keeps a valid index while a run is in progress.
class XdmfSeries {
 public:
  explicit XdmfSeries(std::string xdmf_path);
  // `h5_file_relative`: the snapshot file relative to the folder of the XDMF file (an
  // absolute path is made relative). Adding a file name already listed replaces that entry.
  void add(const std::string& h5_file_relative, const ParticleSnapshot& s);
  void write() const;
  std::size_t size() const { return entries_.size(); }
  const std::string& path() const { return xdmf_path_; }

 private:
  struct Entry {
    std::string file;
    long step;
    double time;
    std::size_t n;
    std::size_t nodes, elements;  // tied FEM mesh, 0 without one
  };
  std::string xdmf_path_;
  std::vector<Entry> entries_;
};

// Comma-separated table; doubles written with round-trip precision (shortest exact form).
// `header` may be empty (no header line); otherwise every row must have header.size() values.
// A restartable state: named arrays of n x width values (row-major), integers, and scalars.
// Written by the driver at the end of every stage/output and read by `tamp run --restart`.
struct Checkpoint {
  struct Real { std::vector<double> values; int width = 1; };
  struct Int { std::vector<int> values; int width = 1; };
  std::map<std::string, Real> reals;
  std::map<std::string, Int> ints;
  std::map<std::string, double> scalars;
};
// HDF5 file with group /checkpoint: one dataset per array (n x width), one attribute per
// scalar. Written to path.tmp and renamed, so an interrupted write never leaves half a file.
// True once closing an HDF5 file failed (a full disk): the library then keeps the file open
// and its clean-up at exit would retry the write forever or crash, so the program must end
// with std::_Exit after reporting (drivers/cli/main.cpp).
bool hdf5_write_failed();
void write_checkpoint_h5(const std::string& path, const Checkpoint& c);
Checkpoint read_checkpoint_h5(const std::string& path);

void write_csv(const std::string& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& rows);

}  // namespace tamp
