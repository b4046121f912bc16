// Results output: HDF5 particle snapshots, XDMF time series, CSV tables.
#include "core/Format.hpp"
#include "core/Output.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <hdf5.h>

namespace tamp {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------- HDF5 RAII wrapper

// Collects HDF5's error stack instead of letting the library print it; restores the
// previous automatic error handler when the outermost operation ends.
class QuietErrors {
 public:
  QuietErrors() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

// The innermost (most specific) message on HDF5's error stack, then clears the stack.
std::string hdf5_detail() {
  std::string innermost;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_UPWARD,
      [](unsigned n, const H5E_error2_t* err, void* data) -> herr_t {
        if (n == 0 && err && err->desc) *static_cast<std::string*>(data) = err->desc;
        return 0;
      },
      &innermost);
  H5Eclear2(H5E_DEFAULT);
  if (innermost.empty()) return std::string();
  // A failed write carries the system's reason ("... error message = 'No space left on
  // device', ..."): that alone; otherwise the text on one line.
  const std::string tag = "error message = '";
  const auto at = innermost.find(tag);
  if (at != std::string::npos) {
    const auto end = innermost.find('\'', at + tag.size());
    if (end != std::string::npos) return " (" + innermost.substr(at + tag.size(), end - at - tag.size()) + ")";
  }
  for (char& c : innermost)
    if (c == '\n' || c == '\r') c = ' ';
  return " (HDF5: " + innermost + ")";
}

// Set when creating or closing a file failed: HDF5 keeps such a file open, and its own clean-up at exit
// then retries the flush (an endless loop or a crash on a full disk). See hdf5_write_failed.
bool g_close_failed = false;

[[noreturn]] void h5_fail(const std::string& what) { throw std::runtime_error(what + hdf5_detail()); }

void h5_check(herr_t status, const std::string& what) {
  if (status < 0) h5_fail(what);
}

// An owned HDF5 identifier, closed by the matching H5?close in the destructor.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle(hid_t id, Closer close, const std::string& what) : id_(id), close_(close) {
    if (id_ < 0) h5_fail(what);
  }
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, -1)), close_(o.close_) {}
  Handle& operator=(Handle&&) = delete;
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;

  hid_t get() const { return id_; }
  // Closes now, reporting failure (the destructor cannot); used for files, where
  // closing flushes the data.
  void close(const std::string& what) {
    const hid_t id = std::exchange(id_, -1);
    if (close_(id) < 0) {
      g_close_failed = true;
      h5_fail(what);
    }
  }

 private:
  hid_t id_ = -1;
  Closer close_ = nullptr;
};

// `path` is created; errors name `label` (the final name of a file written via a temporary).
Handle create_file(const std::string& path, const std::string& label) {
  const hid_t id = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (id < 0) g_close_failed = true;  // a half-created file can stay open in the library too
  return Handle(id, H5Fclose, label + ": cannot create the HDF5 file");
}
Handle open_file(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw std::runtime_error(path + ": the HDF5 file does not exist");
  return Handle(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose,
                path + ": cannot open the HDF5 file");
}
Handle create_group(const Handle& parent, const std::string& name, const std::string& file) {
  return Handle(H5Gcreate2(parent.get(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                file + ": cannot create group " + name);
}
Handle open_group(const Handle& parent, const std::string& name, const std::string& file) {
  return Handle(H5Gopen2(parent.get(), name.c_str(), H5P_DEFAULT), H5Gclose,
                file + ": cannot open group " + name);
}
Handle simple_space(std::initializer_list<hsize_t> dims, const std::string& what) {
  std::vector<hsize_t> d(dims);
  return Handle(H5Screate_simple(static_cast<int>(d.size()), d.data(), nullptr), H5Sclose, what);
}
Handle scalar_space(const std::string& what) { return Handle(H5Screate(H5S_SCALAR), H5Sclose, what); }

// A dataset of the given shape; `file_type` is the stored type, `mem_type` that of `data`.
void write_dataset(const Handle& group, const std::string& name, std::initializer_list<hsize_t> dims,
                   hid_t file_type, hid_t mem_type, const void* data, const char* units,
                   const std::string& where) {
  const std::string what = where + ": cannot write dataset " + name;
  const Handle space = simple_space(dims, what);
  const Handle dset(H5Dcreate2(group.get(), name.c_str(), file_type, space.get(), H5P_DEFAULT,
                               H5P_DEFAULT, H5P_DEFAULT),
                    H5Dclose, what);
  hsize_t count = 1;
  for (const hsize_t d : dims) count *= d;
  if (count > 0) h5_check(H5Dwrite(dset.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), what);

  // "units" string attribute.
  const Handle str(H5Tcopy(H5T_C_S1), H5Tclose, what);
  h5_check(H5Tset_size(str.get(), std::strlen(units) + 1), what);  // NUL-terminated
  const Handle aspace = scalar_space(what);
  const Handle attr(H5Acreate2(dset.get(), "units", str.get(), aspace.get(), H5P_DEFAULT, H5P_DEFAULT),
                    H5Aclose, what);
  h5_check(H5Awrite(attr.get(), str.get(), units), what);
}

void write_scalar_attribute(const Handle& obj, const char* name, hid_t file_type, hid_t mem_type,
                            const void* value, const std::string& where) {
  const std::string what = where + ": cannot write attribute " + name;
  const Handle space = scalar_space(what);
  const Handle attr(H5Acreate2(obj.get(), name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                    what);
  h5_check(H5Awrite(attr.get(), mem_type, value), what);
}

void read_scalar_attribute(const Handle& obj, const char* name, hid_t mem_type, void* value,
                           const std::string& where) {
  const std::string what = where + ": cannot read attribute " + name;
  const Handle attr(H5Aopen(obj.get(), name, H5P_DEFAULT), H5Aclose, what);
  h5_check(H5Aread(attr.get(), mem_type, value), what);
}

// Reads a 1-D dataset into `out` (converted to mem_type by HDF5).
template <class T>
void read_vector(const Handle& group, const std::string& name, hid_t mem_type, std::vector<T>& out,
                 const std::string& where) {
  const std::string what = where + ": cannot read dataset /particles/" + name;
  const Handle dset(H5Dopen2(group.get(), name.c_str(), H5P_DEFAULT), H5Dclose, what);
  const Handle space(H5Dget_space(dset.get()), H5Sclose, what);
  if (H5Sget_simple_extent_ndims(space.get()) != 1)
    throw std::runtime_error(what + ": expected a 1-D dataset");
  hsize_t n = 0;
  H5Sget_simple_extent_dims(space.get(), &n, nullptr);
  out.resize(static_cast<std::size_t>(n));
  if (n > 0) h5_check(H5Dread(dset.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), what);
}

// ---------------------------------------------------------------- field table

using DoubleMember = std::vector<double> ParticleSnapshot::*;

struct DoubleField {
  const char* name;
  DoubleMember member;
  const char* units;
};

const DoubleField kDoubleFields[] = {
    {"r", &ParticleSnapshot::r, "m"},
    {"z", &ParticleSnapshot::z, "m"},
    {"v_r", &ParticleSnapshot::v_r, "m/s"},
    {"v_z", &ParticleSnapshot::v_z, "m/s"},
    {"density", &ParticleSnapshot::density, "kg/m3"},
    {"s_rr", &ParticleSnapshot::s_rr, "Pa"},
    {"s_zz", &ParticleSnapshot::s_zz, "Pa"},
    {"s_tt", &ParticleSnapshot::s_tt, "Pa"},
    {"s_rz", &ParticleSnapshot::s_rz, "Pa"},
    {"plastic_strain", &ParticleSnapshot::plastic_strain, "1"},
    {"internal_energy", &ParticleSnapshot::internal_energy, "J/kg"},
    {"mass", &ParticleSnapshot::mass, "kg"},
};
constexpr const char* kMaterialField = "material";

void check_sizes(const ParticleSnapshot& s, const std::string& where) {
  const std::size_t n = s.size();
  for (const auto& f : kDoubleFields)
    if ((s.*f.member).size() != n)
      throw std::invalid_argument(where + ": snapshot field " + f.name + " has " +
                                  std::to_string((s.*f.member).size()) + " entries, r has " +
                                  std::to_string(n));
  if (s.material.size() != n)
    throw std::invalid_argument(where + ": snapshot field material has " + std::to_string(s.material.size()) +
                                " entries, r has " + std::to_string(n));
}

// ---------------------------------------------------------------- text helpers


std::string xml_escape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// Writes `text` to `path` via "<path>.tmp" and a rename.
void write_text_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error(path + ": cannot create the file (" + std::strerror(errno) + ")");
    out << text;
    out.flush();
    if (!out) throw std::runtime_error(path + ": cannot write the file");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw std::runtime_error(path + ": cannot replace the file (" + ec.message() + ")");
}

// Writes an HDF5 file through `fill(file)` into path.tmp, then renames it over path, so a
// reader never sees a half-written file; the temporary is removed on failure.
template <class Fill>
void write_h5_atomically(const std::string& path, Fill&& fill) {
  const QuietErrors quiet;
  const std::string tmp = path + ".tmp";
  try {
    Handle file = create_file(tmp, path);
    fill(file);
    file.close(path + ": cannot close the HDF5 file");
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw std::runtime_error(path + ": cannot replace the file (" + ec.message() + ")");
}

}  // namespace

bool hdf5_write_failed() { return g_close_failed; }

// ---------------------------------------------------------------- snapshots

void ParticleSnapshot::resize(std::size_t n) {
  for (const auto& f : kDoubleFields) (this->*f.member).resize(n);
  material.resize(n);
}

void write_snapshot_h5(const std::string& path, const ParticleSnapshot& s) {
  check_sizes(s, path);
  const hsize_t n = s.size();
  write_h5_atomically(path, [&](Handle& file) {
    const Handle group = create_group(file, "/particles", path);
    const long long step = s.step;
    write_scalar_attribute(group, "step", H5T_STD_I64LE, H5T_NATIVE_LLONG, &step, path);
    write_scalar_attribute(group, "time", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &s.time, path);
    for (const auto& f : kDoubleFields)
      write_dataset(group, f.name, {n}, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, (s.*f.member).data(), f.units,
                    path);
    write_dataset(group, kMaterialField, {n}, H5T_STD_I32LE, H5T_NATIVE_INT, s.material.data(), "1", path);

    std::vector<double> xyz(3 * s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
      xyz[3 * i + 0] = s.r[i];
      xyz[3 * i + 1] = s.z[i];
      xyz[3 * i + 2] = 0.0;
    }
    write_dataset(group, "coordinates", {n, 3}, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, xyz.data(), "m", path);
    const ElementSnapshot& e = s.elements;
    if (e.size() == 0) return;
    const hsize_t ne = e.size(), nn = e.nodes();
    const Handle eg = create_group(file, "/elements", path);
    write_dataset(eg, "node_r", {nn}, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, e.node_r.data(), "m", path);
    write_dataset(eg, "node_z", {nn}, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, e.node_z.data(), "m", path);
    std::vector<double> nxyz(3 * nn);
    for (std::size_t i = 0; i < nn; ++i) {
      nxyz[3 * i + 0] = e.node_r[i];
      nxyz[3 * i + 1] = e.node_z[i];
      nxyz[3 * i + 2] = 0.0;
    }
    write_dataset(eg, "coordinates", {nn, 3}, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, nxyz.data(), "m", path);
    write_dataset(eg, "connectivity", {ne, 4}, H5T_STD_I32LE, H5T_NATIVE_INT, e.connectivity.data(), "1", path);
    for (const auto& [name, v] : {std::pair<const char*, const std::vector<double>*>{"s_rr", &e.s_rr},
                                  {"s_zz", &e.s_zz}, {"s_tt", &e.s_tt}, {"s_rz", &e.s_rz},
                                  {"plastic_strain", &e.plastic_strain}})
      write_dataset(eg, name, {ne}, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, v->data(), name[0] == 's' ? "Pa" : "1", path);
    write_dataset(eg, "material", {ne}, H5T_STD_I32LE, H5T_NATIVE_INT, e.material.data(), "1", path);
  });
}

ParticleSnapshot read_snapshot_h5(const std::string& path) {
  const QuietErrors quiet;
  ParticleSnapshot s;
  const Handle file = open_file(path);
  const Handle group = open_group(file, "/particles", path);
  long long step = 0;
  read_scalar_attribute(group, "step", H5T_NATIVE_LLONG, &step, path);
  read_scalar_attribute(group, "time", H5T_NATIVE_DOUBLE, &s.time, path);
  s.step = static_cast<long>(step);
  for (const auto& f : kDoubleFields) read_vector(group, f.name, H5T_NATIVE_DOUBLE, s.*f.member, path);
  read_vector(group, kMaterialField, H5T_NATIVE_INT, s.material, path);
  if (H5Lexists(file.get(), "/elements", H5P_DEFAULT) > 0) {
    const Handle eg = open_group(file, "/elements", path);
    ElementSnapshot& e = s.elements;
    read_vector(eg, "node_r", H5T_NATIVE_DOUBLE, e.node_r, path);
    read_vector(eg, "node_z", H5T_NATIVE_DOUBLE, e.node_z, path);
    read_vector(eg, "s_rr", H5T_NATIVE_DOUBLE, e.s_rr, path);
    read_vector(eg, "s_zz", H5T_NATIVE_DOUBLE, e.s_zz, path);
    read_vector(eg, "s_tt", H5T_NATIVE_DOUBLE, e.s_tt, path);
    read_vector(eg, "s_rz", H5T_NATIVE_DOUBLE, e.s_rz, path);
    read_vector(eg, "plastic_strain", H5T_NATIVE_DOUBLE, e.plastic_strain, path);
    read_vector(eg, "material", H5T_NATIVE_INT, e.material, path);
  }
  try {
    check_sizes(s, path);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  return s;
}

// ---------------------------------------------------------------- XDMF

XdmfSeries::XdmfSeries(std::string xdmf_path) : xdmf_path_(std::move(xdmf_path)) {}

void XdmfSeries::add(const std::string& h5_file_relative, const ParticleSnapshot& s) {
  std::string file = h5_file_relative;
  const fs::path p(h5_file_relative);
  if (p.is_absolute()) {
    const fs::path dir = fs::absolute(fs::path(xdmf_path_)).parent_path();
    file = p.lexically_normal().lexically_relative(dir.lexically_normal()).generic_string();
    if (file.empty()) file = h5_file_relative;  // different roots: keep it absolute
  }
  const Entry e{file, s.step, s.time, s.size(), s.elements.nodes(), s.elements.size()};
  for (auto& old : entries_)
    if (old.file == file) {
      old = e;
      return;
    }
  entries_.push_back(e);
}

void XdmfSeries::write() const {
  std::ostringstream o;
  o << "<?xml version=\"1.0\" ?>\n"
    << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
    << "<Xdmf Version=\"3.0\">\n"
    << "  <Domain>\n"
    << "    <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const auto& e : entries_) {
    const std::string file = xml_escape(e.file);
    const std::string n = std::to_string(e.n);
    // with elements: a spatial collection of the particles and the element mesh per time
    if (e.elements > 0)
      o << "      <Grid Name=\"step_" << e.step << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
        << "        <Time Value=\"" << fmt_num(e.time) << "\"/>\n";
    o << "      <Grid Name=\"" << (e.elements > 0 ? "particles" : "step_" + std::to_string(e.step))
      << "\" GridType=\"Uniform\">\n";
    if (e.elements == 0) o << "        <Time Value=\"" << fmt_num(e.time) << "\"/>\n";
    o << ""
      << "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n
      << "\" NodesPerElement=\"1\"/>\n"
      << "        <Geometry GeometryType=\"XYZ\">\n"
      << "          <DataItem Dimensions=\"" << n << " 3\" NumberType=\"Float\" Precision=\"8\" "
      << "Format=\"HDF\">" << file << ":/particles/coordinates</DataItem>\n"
      << "        </Geometry>\n";
    auto attribute = [&](const char* name, const char* number_type, int precision) {
      o << "        <Attribute Name=\"" << name << "\" AttributeType=\"Scalar\" Center=\"Node\">\n"
        << "          <DataItem Dimensions=\"" << n << "\" NumberType=\"" << number_type << "\" Precision=\""
        << precision << "\" Format=\"HDF\">" << file << ":/particles/" << name << "</DataItem>\n"
        << "        </Attribute>\n";
    };
    for (const auto& f : kDoubleFields)
      if (std::strcmp(f.name, "r") != 0 && std::strcmp(f.name, "z") != 0) attribute(f.name, "Float", 8);
    attribute(kMaterialField, "Int", 4);
    o << "      </Grid>\n";
    if (e.elements == 0) continue;
    const std::string ne = std::to_string(e.elements), nn = std::to_string(e.nodes);
    o << "      <Grid Name=\"elements\" GridType=\"Uniform\">\n"
      << "        <Topology TopologyType=\"Quadrilateral\" NumberOfElements=\"" << ne << "\">\n"
      << "          <DataItem Dimensions=\"" << ne << " 4\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">"
      << file << ":/elements/connectivity</DataItem>\n"
      << "        </Topology>\n"
      << "        <Geometry GeometryType=\"XYZ\">\n"
      << "          <DataItem Dimensions=\"" << nn << " 3\" NumberType=\"Float\" Precision=\"8\" "
      << "Format=\"HDF\">" << file << ":/elements/coordinates</DataItem>\n"
      << "        </Geometry>\n";
    for (const char* name : {"s_rr", "s_zz", "s_tt", "s_rz", "plastic_strain", "material"}) {
      const bool is_int = std::strcmp(name, "material") == 0;
      o << "        <Attribute Name=\"" << name << "\" AttributeType=\"Scalar\" Center=\"Cell\">\n"
        << "          <DataItem Dimensions=\"" << ne << "\" NumberType=\"" << (is_int ? "Int" : "Float")
        << "\" Precision=\"" << (is_int ? 4 : 8) << "\" Format=\"HDF\">" << file << ":/elements/" << name
        << "</DataItem>\n"
        << "        </Attribute>\n";
    }
    o << "      </Grid>\n"
      << "      </Grid>\n";
  }
  o << "    </Grid>\n"
    << "  </Domain>\n"
    << "</Xdmf>\n";
  write_text_atomically(xdmf_path_, o.str());
}

// ---------------------------------------------------------------- CSV

void write_csv(const std::string& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& rows) {
  if (!header.empty())
    for (std::size_t i = 0; i < rows.size(); ++i)
      if (rows[i].size() != header.size())
        throw std::invalid_argument(path + ": CSV row " + std::to_string(i) + " has " +
                                    std::to_string(rows[i].size()) + " values, the header has " +
                                    std::to_string(header.size()));
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error(path + ": cannot create the CSV file (" + std::strerror(errno) + ")");
  for (std::size_t j = 0; j < header.size(); ++j) out << (j ? "," : "") << csv_field(header[j]);
  if (!header.empty()) out << '\n';
  std::string line;
  for (const auto& row : rows) {
    line.clear();
    for (std::size_t j = 0; j < row.size(); ++j) {
      if (j) line += ',';
      line += fmt_num(row[j]);
    }
    line += '\n';
    out << line;
  }
  out.flush();
  if (!out) throw std::runtime_error(path + ": cannot write the CSV file");
}


// ---------------------------------------------------------------- checkpoints

namespace {
std::string join_names(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ",") + n;
  return s;
}
std::vector<std::string> split_names(const std::string& s) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start < s.size()) {
    const std::size_t end = s.find(',', start);
    out.push_back(s.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return out;
}
void write_string_attribute(const Handle& obj, const char* name, const std::string& value, const std::string& where) {
  const std::string what = where + ": cannot write attribute " + name;
  const Handle str(H5Tcopy(H5T_C_S1), H5Tclose, what);
  h5_check(H5Tset_size(str.get(), value.size() + 1), what);
  const Handle space = scalar_space(what);
  const Handle attr(H5Acreate2(obj.get(), name, str.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose, what);
  h5_check(H5Awrite(attr.get(), str.get(), value.c_str()), what);
}
std::string read_string_attribute(const Handle& obj, const char* name, const std::string& where) {
  const std::string what = where + ": cannot read attribute " + name;
  const Handle attr(H5Aopen(obj.get(), name, H5P_DEFAULT), H5Aclose, what);
  const Handle type(H5Aget_type(attr.get()), H5Tclose, what);
  std::vector<char> buf(H5Tget_size(type.get()) + 1, '\0');
  h5_check(H5Aread(attr.get(), type.get(), buf.data()), what);
  return std::string(buf.data());
}
// Reads an n x width dataset (or 1-D) as row-major values.
template <class T>
void read_table(const Handle& group, const std::string& name, hid_t mem_type, std::vector<T>& out, int& width,
                const std::string& where) {
  const std::string what = where + ": cannot read dataset /checkpoint/" + name;
  const Handle dset(H5Dopen2(group.get(), name.c_str(), H5P_DEFAULT), H5Dclose, what);
  const Handle space(H5Dget_space(dset.get()), H5Sclose, what);
  const int nd = H5Sget_simple_extent_ndims(space.get());
  if (nd < 1 || nd > 2) throw std::runtime_error(what + ": expected a 1-D or 2-D dataset");
  hsize_t dims[2] = {0, 1};
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  width = static_cast<int>(nd == 2 ? dims[1] : 1);
  out.resize(static_cast<std::size_t>(dims[0] * (nd == 2 ? dims[1] : 1)));
  if (!out.empty()) h5_check(H5Dread(dset.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), what);
}
}  // namespace

void write_checkpoint_h5(const std::string& path, const Checkpoint& c) {
  write_h5_atomically(path, [&](Handle& file) {
    const Handle group = create_group(file, "/checkpoint", path);
    std::vector<std::string> real_names, int_names, scalar_names;
    for (const auto& [name, a] : c.reals) {
      const hsize_t w = static_cast<hsize_t>(a.width), n = a.values.size() / w;
      write_dataset(group, name, {n, w}, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, a.values.data(), "SI", path);
      real_names.push_back(name);
    }
    for (const auto& [name, a] : c.ints) {
      const hsize_t w = static_cast<hsize_t>(a.width), n = a.values.size() / w;
      write_dataset(group, name, {n, w}, H5T_STD_I32LE, H5T_NATIVE_INT, a.values.data(), "1", path);
      int_names.push_back(name);
    }
    for (const auto& [name, v] : c.scalars) {
      write_scalar_attribute(group, name.c_str(), H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &v, path);
      scalar_names.push_back(name);
    }
    write_string_attribute(group, "real_fields", join_names(real_names), path);
    write_string_attribute(group, "int_fields", join_names(int_names), path);
    write_string_attribute(group, "scalars", join_names(scalar_names), path);
  });
}

Checkpoint read_checkpoint_h5(const std::string& path) {
  const QuietErrors quiet;
  Checkpoint c;
  const Handle file = open_file(path);
  const Handle group = open_group(file, "/checkpoint", path);
  for (const auto& name : split_names(read_string_attribute(group, "real_fields", path))) {
    auto& a = c.reals[name];
    read_table(group, name, H5T_NATIVE_DOUBLE, a.values, a.width, path);
  }
  for (const auto& name : split_names(read_string_attribute(group, "int_fields", path))) {
    auto& a = c.ints[name];
    read_table(group, name, H5T_NATIVE_INT, a.values, a.width, path);
  }
  for (const auto& name : split_names(read_string_attribute(group, "scalars", path)))
    read_scalar_attribute(group, name.c_str(), H5T_NATIVE_DOUBLE, &c.scalars[name], path);
  return c;
}

}  // namespace tamp
