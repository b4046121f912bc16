// Input decks: parsing, validation messages, round trip through to_toml.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "core/Deck.hpp"

using tamp::Config;
using tamp::DeckError;
using tamp::parse_deck;
using tamp::WallType;

namespace {

const char* const kValidDeck = R"(# a footing on two layers
gravity = 9.8
damping = 5            # integer where a float is expected

[run]
name = "footing"
end_time = 0.5
output_interval = 0.01
cfl = 0.25
progress_interval = 1
max_steps = 1000

[sph]
spacing = 0.005
h_factor = 1.5
alpha = 1.0
beta = 2
artificial_stress = 0.2
artificial_stress_n = 4
regularise_every = 20
kernel_correction = false
neighbour_skin = 0.1
axis_radius_factor = 0.25

[[materials]]
name = "sand"
model = "mohr-coulomb"
unit_weight = 18000
G = 1e7
nu = 0.3
c = 500
phi_deg = 30
psi_deg = 5
tension_cutoff = 100

[[materials]]
name = "clay"
model = "tresca"
density = 1700
G = 5e6
nu = 0.49
Su = 20e3

[[materials]]
name = "steel"
model = "elastic"
density = 7850
G = 80e9
nu = 0.0

[[blocks]]
material = "sand"
r = [0, 0.5]
z = [0, 0.3]

[[blocks]]
material = "clay"
r = [0.0, 0.5]
z = [0.3, 0.6]
velocity = [0, -1.5]

[boundaries]
bottom = { type = "fixed", z = 0 }
outer = { type = "roller", r = 0.5 }
)";

// A minimal valid deck, assembled from parts so that tests can change one of them.
struct Parts {
  std::string top;  // top-level keys (must precede the tables)
  std::string sph = "[sph]\nspacing = 0.01\n";
  std::string materials =
      "[[materials]]\nname = \"soil\"\nmodel = \"elastic\"\ndensity = 2000\nG = 1e6\nnu = 0.3\n";
  std::string blocks = "[[blocks]]\nmaterial = \"soil\"\nr = [0, 1]\nz = [0, 1]\n";
  std::string rest;
  std::string text() const { return top + "\n" + sph + "\n" + materials + "\n" + blocks + "\n" + rest; }
};

// Parses `text` expecting a DeckError whose message contains every one of `parts`.
std::string require_error(const std::string& text, const std::vector<std::string>& parts) {
  std::string msg;
  try {
    parse_deck(text, "deck.toml");
  } catch (const DeckError& e) {
    msg = e.what();
  }
  INFO("deck:\n" << text);
  REQUIRE(!msg.empty());
  INFO("message: " << msg);
  CHECK(msg.rfind("deck.toml: ", 0) == 0);
  for (const auto& p : parts) CHECK_THAT(msg, Catch::Contains(p));
  return msg;
}

void require_same(const Config& a, const Config& b) {
  CHECK(a.run.name == b.run.name);
  CHECK(a.run.end_time == b.run.end_time);
  CHECK(a.run.output_interval == b.run.output_interval);
  CHECK(a.run.cfl == b.run.cfl);
  CHECK(a.run.progress_interval == b.run.progress_interval);
  CHECK(a.run.max_steps == b.run.max_steps);
  CHECK(a.sph.spacing == b.sph.spacing);
  CHECK(a.sph.h_factor == b.sph.h_factor);
  CHECK(a.sph.alpha == b.sph.alpha);
  CHECK(a.sph.beta == b.sph.beta);
  CHECK(a.sph.artificial_stress == b.sph.artificial_stress);
  CHECK(a.sph.artificial_stress_n == b.sph.artificial_stress_n);
  CHECK(a.sph.regularise_every == b.sph.regularise_every);
  CHECK(a.sph.kernel_correction == b.sph.kernel_correction);
  CHECK(a.sph.neighbour_skin == b.sph.neighbour_skin);
  CHECK(a.sph.axis_radius_factor == b.sph.axis_radius_factor);
  CHECK(a.gravity == b.gravity);
  CHECK(a.damping == b.damping);
  CHECK(a.gravity_ramp == b.gravity_ramp);
  CHECK(a.initial_stress == b.initial_stress);
  REQUIRE(a.materials.size() == b.materials.size());
  for (std::size_t i = 0; i < a.materials.size(); ++i) {
    const auto& x = a.materials[i];
    const auto& y = b.materials[i];
    CHECK(x.name == y.name);
    CHECK(x.model == y.model);
    CHECK(x.density == y.density);
    CHECK(x.shear_modulus == y.shear_modulus);
    CHECK(x.poisson_ratio == y.poisson_ratio);
    CHECK(x.cohesion == y.cohesion);
    CHECK(x.phi_deg == y.phi_deg);
    CHECK(x.psi_deg == y.psi_deg);
    CHECK(x.tension_cutoff == y.tension_cutoff);
    CHECK(x.separation_density == y.separation_density);
    CHECK(x.mass_scaling == y.mass_scaling);
    CHECK(x.viscosity == y.viscosity);
    CHECK(x.viscosity_head_on == y.viscosity_head_on);
  }
  REQUIRE(a.blocks.size() == b.blocks.size());
  for (std::size_t i = 0; i < a.blocks.size(); ++i) {
    const auto& x = a.blocks[i];
    const auto& y = b.blocks[i];
    CHECK(x.material == y.material);
    CHECK(x.r_min == y.r_min);
    CHECK(x.r_max == y.r_max);
    CHECK(x.z_min == y.z_min);
    CHECK(x.z_max == y.z_max);
    CHECK(x.velocity_r == y.velocity_r);
    CHECK(x.velocity_z == y.velocity_z);
  }
  for (auto [w, v] : {std::pair{a.bottom, b.bottom}, std::pair{a.top, b.top}, std::pair{a.outer, b.outer}}) {
    CHECK(w.type == v.type);
    CHECK(w.position == v.position);
  }
}

std::filesystem::path temp_dir(const std::string& tag) {
  std::random_device rd;
  auto dir = std::filesystem::temp_directory_path() / ("tamp_" + tag + "_" + std::to_string(rd()));
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace

TEST_CASE("Deck: a valid deck parses with the right values", "[deck]") {
  const Config c = parse_deck(kValidDeck, "valid.toml");
  CHECK(c.source_file == "valid.toml");
  CHECK(c.gravity == 9.8);
  CHECK(c.damping == 5.0);
  CHECK(c.run.name == "footing");
  CHECK(c.run.end_time == 0.5);
  CHECK(c.run.output_interval == 0.01);
  CHECK(c.run.cfl == 0.25);
  CHECK(c.run.progress_interval == 1.0);
  CHECK(c.run.max_steps == 1000);
  CHECK(c.sph.spacing == 0.005);
  CHECK(c.sph.h_factor == 1.5);
  CHECK(c.sph.alpha == 1.0);
  CHECK(c.sph.beta == 2.0);
  CHECK(c.sph.artificial_stress == 0.2);
  CHECK(c.sph.artificial_stress_n == 4.0);
  CHECK(c.sph.regularise_every == 20);
  CHECK(c.sph.kernel_correction == false);
  CHECK(c.sph.neighbour_skin == 0.1);
  CHECK(c.sph.axis_radius_factor == 0.25);

  REQUIRE(c.materials.size() == 3);
  const auto& sand = c.materials[0];
  CHECK(sand.name == "sand");
  CHECK(sand.model == "mohr-coulomb");
  CHECK(sand.density == Approx(18000.0 / 9.81).epsilon(1e-15));
  CHECK(sand.shear_modulus == 1e7);
  CHECK(sand.poisson_ratio == 0.3);
  CHECK(sand.cohesion == 500.0);
  CHECK(sand.phi_deg == 30.0);
  CHECK(sand.psi_deg == 5.0);
  CHECK(sand.tension_cutoff == 100.0);
  const auto& clay = c.materials[1];
  CHECK(clay.name == "clay");
  CHECK(clay.model == "tresca");
  CHECK(clay.density == 1700.0);
  CHECK(clay.shear_modulus == 5e6);
  CHECK(clay.poisson_ratio == 0.49);
  CHECK(clay.cohesion == 20e3);
  CHECK(clay.phi_deg == 0.0);
  CHECK(clay.psi_deg == 0.0);
  CHECK(clay.tension_cutoff == 0.0);
  const auto& steel = c.materials[2];
  CHECK(steel.model == "elastic");
  CHECK(steel.poisson_ratio == 0.0);
  CHECK(steel.cohesion == 0.0);

  REQUIRE(c.blocks.size() == 2);
  CHECK(c.blocks[0].material == "sand");
  CHECK(c.blocks[0].r_min == 0.0);
  CHECK(c.blocks[0].r_max == 0.5);
  CHECK(c.blocks[0].z_min == 0.0);
  CHECK(c.blocks[0].z_max == 0.3);
  CHECK(c.blocks[0].velocity_r == 0.0);
  CHECK(c.blocks[0].velocity_z == 0.0);
  CHECK(c.blocks[1].material == "clay");
  CHECK(c.blocks[1].z_min == 0.3);
  CHECK(c.blocks[1].z_max == 0.6);
  CHECK(c.blocks[1].velocity_z == -1.5);

  CHECK(c.bottom.type == WallType::Fixed);
  CHECK(c.bottom.position == 0.0);
  CHECK(c.top.type == WallType::None);
  CHECK(c.outer.type == WallType::Roller);
  CHECK(c.outer.position == 0.5);
}

TEST_CASE("Deck: omitted keys keep the defaults of Config.hpp", "[deck]") {
  const Config c = parse_deck(Parts{}.text(), "minimal.toml");
  const Config d;
  CHECK(c.run.name == d.run.name);
  CHECK(c.run.end_time == d.run.end_time);
  CHECK(c.run.cfl == d.run.cfl);
  CHECK(c.run.max_steps == d.run.max_steps);
  CHECK(c.sph.h_factor == d.sph.h_factor);
  CHECK(c.sph.artificial_stress_n == d.sph.artificial_stress_n);
  CHECK(c.sph.kernel_correction == d.sph.kernel_correction);
  CHECK(c.gravity == d.gravity);
  CHECK(c.damping == d.damping);
  CHECK(c.bottom.type == WallType::None);
  CHECK(c.materials[0].phi_deg == 0.0);
  CHECK(c.materials[0].tension_cutoff == 0.0);
}

TEST_CASE("Deck: to_toml round trip gives the same Config", "[deck]") {
  SECTION("from a parsed deck") {
    const Config a = parse_deck(kValidDeck, "valid.toml");
    const std::string text = tamp::to_toml(a);
    INFO(text);
    const Config b = parse_deck(text, "roundtrip.toml");
    require_same(a, b);
  }
  SECTION("from a Config built in code, with awkward values") {
    Config a;
    a.run.name = "odd \"name\"\twith\\escapes\n";
    a.run.end_time = 0.1 + 0.2;
    a.run.max_steps = 123456789012L;
    a.sph.spacing = 1.0 / 3.0;
    a.sph.kernel_correction = false;
    a.gravity = 0;
    a.damping = 1e-300;
    tamp::MaterialSpec m;
    m.name = "ünïcode soil";
    m.model = "mohr-coulomb";
    m.density = 1234.5678901234567;
    m.shear_modulus = 2.5e8;
    m.poisson_ratio = 0.4999999;
    m.cohesion = 1e3;
    m.phi_deg = 35.123456789;
    m.psi_deg = 35.123456789;
    m.tension_cutoff = 5;
    m.separation_density = 1000.0 / 0.9;
    m.mass_scaling = 6.08;
    m.viscosity = 0.2;
    m.viscosity_head_on = 0.75;
    a.materials.push_back(m);
    tamp::MaterialSpec t;
    t.name = "clay";
    t.model = "tresca";
    t.density = 1800;
    t.shear_modulus = 1e6;
    t.poisson_ratio = 0.45;
    t.cohesion = 12345.6;
    a.materials.push_back(t);
    a.blocks.push_back({"clay", 0.0, 0.7, -0.25, 1e-3, 0.1, -2.0 / 7.0});
    // at least one particle (spacing 1/3 m) across, or validation refuses the model
    a.blocks.push_back({m.name, 0.1, 0.6, 5.0, 6.0, 0.0, 0.0});
    a.bottom = {WallType::Roller, -0.25};
    a.top = {WallType::Fixed, 2.0};
    a.outer = {WallType::None, 0.0};
    const std::string text = tamp::to_toml(a);
    INFO(text);
    const Config b = parse_deck(text, "roundtrip.toml");
    require_same(a, b);
  }
}

TEST_CASE("Deck: the message has the documented form", "[deck]") {
  Parts p;
  p.materials += "[[materials]]\nname = \"clay\"\nmodel = \"elastic\"\ndensity = 1800\nG = 1e6\nnu = 0.6\n";
  const std::string msg = require_error(p.text(), {});
  CHECK(msg == "deck.toml: materials[1].nu = 0.6 is out of range; allowed: 0 <= nu < 0.5");
}

TEST_CASE("Deck: unknown keys are rejected", "[deck]") {
  SECTION("top level") {
    Parts p;
    p.top = "gravty = 9.81\n";
    require_error(p.text(), {"gravty = 9.81", "is not a known key", "gravity"});
  }
  SECTION("inside [[materials]]") {
    Parts p;
    p.materials +=
        "[[materials]]\nname = \"b\"\nmodel = \"elastic\"\ndensity = 1\nG = 1\nnu = 0\ncolour = \"red\"\n";
    require_error(p.text(), {"materials[1].colour = \"red\"", "is not a known key", "tension_cutoff"});
  }
  SECTION("inside [run]") {
    Parts p;
    p.rest = "[run]\nend_tme = 1.0\n";
    require_error(p.text(), {"run.end_tme = 1.0", "is not a known key"});
  }
  SECTION("inside an inline boundary table") {
    Parts p;
    p.rest = "[boundaries]\nbottom = { type = \"fixed\", r = 0.0 }\n";
    require_error(p.text(), {"boundaries.bottom.r = 0.0", "is not a known key", "type, z"});
  }
  SECTION("inside [[blocks]]") {
    Parts p;
    p.blocks += "[[blocks]]\nmaterial = \"soil\"\nr = [0, 1]\nz = [1, 2]\nvelocty = [0, 1]\n";
    require_error(p.text(), {"blocks[1].velocty = [0, 1]", "is not a known key"});
  }
}

TEST_CASE("Deck: wrong types are rejected", "[deck]") {
  SECTION("string for a number") {
    Parts p;
    p.rest = "[run]\nend_time = \"long\"\n";
    require_error(p.text(), {"run.end_time = \"long\"", "wrong type (string)", "end_time > 0"});
  }
  SECTION("float for an integer") {
    Parts p;
    p.rest = "[run]\nmax_steps = 1.5\n";
    require_error(p.text(), {"run.max_steps = 1.5", "wrong type (float)", "an integer"});
  }
  SECTION("number for a boolean") {
    Parts p;
    p.sph += "kernel_correction = 1\n";
    require_error(p.text(), {"sph.kernel_correction = 1", "wrong type (integer)", "true or false"});
  }
  SECTION("table where an array of tables is expected") {
    Parts p;
    p.materials = "[materials]\nname = \"soil\"\n";
    require_error(p.text(), {"materials = { name = \"soil\" }", "wrong type (table)", "[[materials]]"});
  }
  SECTION("array element") {
    Parts p;
    p.blocks = "[[blocks]]\nmaterial = \"soil\"\nr = [0, \"1\"]\nz = [0, 1]\n";
    require_error(p.text(), {"blocks[0].r[1] = \"1\"", "wrong type (string)"});
  }
}

TEST_CASE("Deck: out-of-range values are rejected", "[deck]") {
  SECTION("nu = 0.5") {
    Parts p;
    p.materials = "[[materials]]\nname = \"soil\"\nmodel = \"elastic\"\ndensity = 2000\nG = 1e6\nnu = 0.5\n";
    require_error(p.text(), {"materials[0].nu = 0.5", "out of range", "0 <= nu < 0.5"});
  }
  // phi and psi are keys of the plastic models: the fixture's elastic soil made Mohr-Coulomb
  const std::string mohr_coulomb =
      "[[materials]]\nname = \"soil\"\nmodel = \"mohr-coulomb\"\ndensity = 2000\nG = 1e6\nnu = 0.3\n";
  SECTION("phi_deg = 90") {
    Parts p;
    p.materials = mohr_coulomb + "phi_deg = 90\n";
    require_error(p.text(), {"materials[0].phi_deg = 90", "out of range", "0 <= phi_deg < 90"});
  }
  SECTION("negative density") {
    Parts p;
    p.materials = "[[materials]]\nname = \"soil\"\nmodel = \"elastic\"\ndensity = -1800\nG = 1e6\nnu = 0.3\n";
    require_error(p.text(), {"materials[0].density = -1800", "out of range", "density > 0"});
  }
  SECTION("psi above phi") {
    Parts p;
    p.materials = mohr_coulomb + "phi_deg = 20\npsi_deg = 25.5\n";
    require_error(p.text(), {"materials[0].psi_deg = 25.5", "psi_deg <= phi_deg"});
  }
  SECTION("separation density not below the density") {
    Parts p;
    p.materials = mohr_coulomb + "separation_density = 2000\n";
    require_error(p.text(), {"materials[0].separation_density = 2000", "is not below the material's density 2000",
                             "grain density / (1 + e_max)"});
  }
  SECTION("mass scaling below 1") {
    Parts p;
    p.materials += "mass_scaling = 0.5\n";
    require_error(p.text(), {"materials[0].mass_scaling = 0.5", "1 <= mass_scaling <= 100"});
  }
  SECTION("a material's viscosity out of range") {
    Parts p;
    p.materials += "viscosity = -0.1\n";
    require_error(p.text(), {"materials[0].viscosity = -0.1", "0 <= viscosity <= 10"});
  }
  SECTION("mass scaling with elements") {
    Parts p;
    p.materials += "mass_scaling = 4\n";
    p.rest = "[fem]\nsph_zone = { r = [0, 0.3], z = [0.5, 1.0] }\n";
    require_error(p.text(), {"materials[0].mass_scaling = 4", "with [fem] enabled = true (material 'soil')",
                             "1 (no mass scaling) with [fem] enabled, or [fem] enabled = false"});
  }
  SECTION("cfl above 1") {
    Parts p;
    p.rest = "[run]\ncfl = 1.2\n";
    require_error(p.text(), {"run.cfl = 1.2", "0 < cfl <= 1"});
  }
  SECTION("inverted block") {
    Parts p;
    p.blocks = "[[blocks]]\nmaterial = \"soil\"\nr = [0.5, 0.2]\nz = [0, 1]\n";
    require_error(p.text(), {"blocks[0].r = [0.5, 0.2]", "out of range", "r_min < r_max"});
  }
  SECTION("non-finite value") {
    Parts p;
    p.top = "gravity = inf\n";
    require_error(p.text(), {"gravity = inf", "not a finite number"});
  }
  SECTION("unknown model") {
    Parts p;
    p.materials = "[[materials]]\nname = \"soil\"\nmodel = \"cam-clay\"\ndensity = 2000\nG = 1e6\nnu = 0.3\n";
    require_error(p.text(), {"materials[0].model = \"cam-clay\"", "\"mohr-coulomb\""});
  }
  SECTION("top wall below the bottom wall") {
    Parts p;
    p.rest = "[boundaries]\nbottom = { type = \"fixed\", z = 1.0 }\ntop = { type = \"roller\", z = 0.5 }\n";
    require_error(p.text(), {"boundaries.top.z = 0.5", "top.z > bottom.z"});
  }
}

TEST_CASE("Deck: material rules", "[deck]") {
  const std::string head = "[[materials]]\nname = \"m\"\nG = 1e6\nnu = 0.3\n";
  SECTION("density and unit_weight together") {
    Parts p;
    p.materials = head + "model = \"elastic\"\ndensity = 2000\nunit_weight = 19620\n";
    p.blocks = "[[blocks]]\nmaterial = \"m\"\nr = [0, 1]\nz = [0, 1]\n";
    require_error(p.text(), {"materials[0].unit_weight = 19620", "exactly one of density"});
  }
  SECTION("neither density nor unit_weight") {
    Parts p;
    p.materials = head + "model = \"elastic\"\n";
    require_error(p.text(), {"materials[0].density is missing", "exactly one of density"});
  }
  SECTION("tresca with c") {
    Parts p;
    p.materials = head + "model = \"tresca\"\ndensity = 2000\nc = 1000\n";
    require_error(p.text(), {"materials[0].c = 1000", "Su"});
  }
  SECTION("tresca with phi") {
    Parts p;
    p.materials = head + "model = \"tresca\"\ndensity = 2000\nSu = 1000\nphi_deg = 10\n";
    require_error(p.text(), {"materials[0].phi_deg = 10", "tresca"});
  }
  SECTION("tresca without Su") {
    Parts p;
    p.materials = head + "model = \"tresca\"\ndensity = 2000\n";
    require_error(p.text(), {"materials[0].Su is missing", "Su > 0"});
  }
  SECTION("a key the model does not read") {
    // An elastic material used to accept phi_deg and ignore it: now each model reads only
    // the keys it declares (core/MaterialModel.hpp).
    Parts p;
    p.materials = head + "model = \"elastic\"\ndensity = 2000\nphi_deg = 30\n";
    require_error(p.text(), {"materials[0].phi_deg = 30", "is not used by model \"elastic\"", "G, nu"});
  }
  SECTION("duplicate names") {
    Parts p;
    p.materials += "\n" + head + "model = \"elastic\"\ndensity = 1\n" + head +
                   "model = \"elastic\"\ndensity = 1\n";
    require_error(p.text(), {"materials[2].name = \"m\"", "materials[1]"});
  }
}

TEST_CASE("Deck: a block must name a known material", "[deck]") {
  Parts p;
  p.blocks = "[[blocks]]\nmaterial = \"rock\"\nr = [0, 1]\nz = [0, 1]\n";
  require_error(p.text(), {"blocks[0].material = \"rock\"", "not a known material", "\"soil\""});
}

TEST_CASE("Deck: spacing is required", "[deck]") {
  SECTION("no [sph] table") {
    Parts p;
    p.sph = "";
    require_error(p.text(), {"sph.spacing is missing", "spacing > 0"});
  }
  SECTION("[sph] without spacing") {
    Parts p;
    p.sph = "[sph]\nh_factor = 1.2\n";
    require_error(p.text(), {"sph.spacing is missing", "spacing > 0"});
  }
}

TEST_CASE("Deck: at least one material and one block", "[deck]") {
  SECTION("no blocks") {
    Parts p;
    p.blocks = "";
    require_error(p.text(), {"blocks is missing", "[[blocks]]"});
  }
  SECTION("empty blocks array") {
    Parts p;
    p.blocks = "";
    p.top = "blocks = []\n";
    require_error(p.text(), {"blocks = []", "has no entries", "at least one"});
  }
  SECTION("no materials") {
    Parts p;
    p.materials = "";
    require_error(p.text(), {"materials is missing", "[[materials]]"});
  }
}

TEST_CASE("Deck: a TOML syntax error names the line and column", "[deck]") {
  const std::string text = "[run]\nend_time = 0.1\nname = \"unterminated\n";
  const std::string msg = require_error(text, {"syntax error", "line 3", "column"});
  (void)msg;
}

TEST_CASE("Deck: load_deck reads a file and names it in errors", "[deck]") {
  const auto dir = temp_dir("deck");
  const std::string good = (dir / "good.toml").string();
  const std::string bad = (dir / "bad.toml").string();
  {
    std::ofstream(good) << kValidDeck;
    Parts p;
    p.rest = "[run]\nend_time = -1\n";
    std::ofstream(bad) << p.text();
  }
  const Config c = tamp::load_deck(good);
  CHECK(c.source_file == good);
  CHECK(c.run.name == "footing");
  CHECK(c.materials.size() == 3);

  try {
    tamp::load_deck(bad);
    FAIL("expected a DeckError");
  } catch (const DeckError& e) {
    CHECK_THAT(e.what(), Catch::StartsWith(bad + ": run.end_time = -1 is out of range"));
  }
  const std::string missing = (dir / "missing.toml").string();
  try {
    tamp::load_deck(missing);
    FAIL("expected a DeckError");
  } catch (const DeckError& e) {
    CHECK_THAT(e.what(), Catch::Contains(missing));
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("Deck: materials_from takes another deck's materials, and is refused with [[materials]] or a bad path",
          "[deck]") {
  const auto dir = temp_dir("materials_from");
  const std::string source = (dir / "source.toml").string();
  std::ofstream(source) << kValidDeck;
  const Config want = tamp::load_deck(source);
  auto deck_with = [&](const std::string& top_lines, bool own_materials) {
    Parts p;
    p.top = top_lines + "\n" + p.top;
    if (!own_materials) p.materials = "";
    p.blocks = "[[blocks]]\nmaterial = \"" + want.materials[0].name + "\"\nr = [0, 1]\nz = [0, 1]\n";
    const std::string path = (dir / "deck.toml").string();
    std::ofstream(path) << p.text();
    return path;
  };
  SECTION("the materials are the other deck's, in its order, with --set applied to them") {
    const Config c = tamp::load_deck(deck_with("materials_from = \"source.toml\"", false));
    REQUIRE(c.materials.size() == want.materials.size());
    for (size_t k = 0; k < c.materials.size(); ++k) {
      CHECK(c.materials[k].name == want.materials[k].name);
      CHECK(c.materials[k].shear_modulus == want.materials[k].shear_modulus);
    }
    const std::string name = want.materials[0].name;
    const Config s = tamp::load_deck(deck_with("materials_from = \"source.toml\"", false), {name + ".G=7e6"});
    CHECK(s.materials[0].shear_modulus == 7e6);
  }
  SECTION("refused: both given, a missing file, not a string") {
    auto error_of = [&](const std::string& path) {
      try {
        tamp::load_deck(path);
      } catch (const DeckError& e) {
        return std::string(e.what());
      }
      return std::string();
    };
    CHECK_THAT(error_of(deck_with("materials_from = \"source.toml\"", true)),
               Catch::Contains("materials_from = \"source.toml\" and [[materials]] both given; allowed: one of them"));
    CHECK_THAT(error_of(deck_with("materials_from = \"nowhere.toml\"", false)),
               Catch::Contains("materials_from = \"nowhere.toml\"") && Catch::Contains("does not exist"));
    CHECK_THAT(error_of(deck_with("materials_from = 3", false)), Catch::Contains("materials_from is not a string"));
  }
  SECTION("a bad material in the other deck is reported with the file it is written in") {
    std::string text = kValidDeck;
    const size_t at = text.find("nu = 0.3");
    REQUIRE(at != std::string::npos);
    text.replace(at, 8, "nu = 0.7");
    std::ofstream(source) << text;
    try {
      tamp::load_deck(deck_with("materials_from = \"source.toml\"", false));
      FAIL("expected a DeckError");
    } catch (const DeckError& e) {
      CHECK_THAT(e.what(), Catch::Contains("nu") && Catch::Contains("(the materials are those of"));
    }
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("Deck: non-reflecting boundaries parse and round-trip", "[deck]") {
  Parts p;
  p.rest = "[boundaries]\nbottom = { type = \"non-reflecting\", z = 0 }\nouter = { type = \"non-reflecting\", r = 1.0 }\n";
  const Config c = parse_deck(p.text(), "deck.toml");
  CHECK(c.bottom.type == WallType::NonReflecting);
  CHECK(c.outer.type == WallType::NonReflecting);
  CHECK(c.outer.position == 1.0);
  const Config d = parse_deck(to_toml(c), "round-trip.toml");
  CHECK(d.bottom.type == WallType::NonReflecting);
  CHECK(d.outer.position == 1.0);
  p.rest = "[boundaries]\nouter = { type = \"absorbing\", r = 1.0 }\n";
  require_error(p.text(), {"deck.toml", "boundaries.outer.type", "absorbing", "non-reflecting"});
  // spring_distance: default automatic (-1), explicit values round-trip, 0 = dashpots only
  CHECK(c.outer.spring_distance < 0);
  p.rest = "[boundaries]\nouter = { type = \"non-reflecting\", r = 1.0, spring_distance = 0.75 }\n"
           "bottom = { type = \"non-reflecting\", z = 0, spring_distance = 0 }\n";
  const Config e = parse_deck(p.text(), "deck.toml");
  CHECK(e.outer.spring_distance == 0.75);
  CHECK(e.bottom.spring_distance == 0.0);
  const Config f = parse_deck(to_toml(e), "round-trip.toml");
  CHECK(f.outer.spring_distance == 0.75);
  CHECK(f.bottom.spring_distance == 0.0);
  p.rest = "[boundaries]\nouter = { type = \"non-reflecting\", r = 1.0, spring_distance = -0.5 }\n";
  require_error(p.text(), {"deck.toml", "boundaries.outer.spring_distance", "-0.5", "spring_distance >= 0"});
  p.rest = "[boundaries]\nouter = { type = \"roller\", r = 1.0, spring_distance = 0.5 }\n";
  require_error(p.text(), {"deck.toml", "boundaries.outer.spring_distance", "0.5", "non-reflecting"});
}

TEST_CASE("Deck: initial_stress takes zero or geostatic", "[deck]") {
  Parts p;
  p.top = "initial_stress = \"geostatic\"\n";
  CHECK(parse_deck(p.text(), "deck.toml").initial_stress == "geostatic");
  CHECK(parse_deck(Parts{}.text(), "deck.toml").initial_stress == "zero");
  p.top = "initial_stress = \"k0\"\n";
  require_error(p.text(), {"deck.toml", "initial_stress", "k0", "geostatic"});
}

TEST_CASE("Deck: the drop-sequence sections parse, validate and round-trip", "[deck]") {
  const std::string lab = std::string(TAMP_SOURCE_DIR) + "/examples/lab-test.toml";
  const Config c = tamp::load_deck(lab);
  CHECK(c.schedule.enabled);
  CHECK(c.schedule.drop_heights.size() == 36);
  CHECK(c.schedule.backfill_after.size() == 21);
  CHECK(c.pounder.mass == 10.55);
  CHECK(c.pounder.max_diameter == 0.1);
  CHECK(c.contact.static_friction == 0.5);
  CHECK(c.contact.dynamic_friction == 0.4);
  CHECK(c.backfill.material == "aggregate");
  CHECK(c.tracers.size() == 2);
  const Config d = parse_deck(to_toml(c), "round-trip.toml");
  CHECK(d.schedule.drop_heights == c.schedule.drop_heights);
  CHECK(d.schedule.backfill_after == c.schedule.backfill_after);
  CHECK(d.schedule.drop_height_from == c.schedule.drop_height_from);
  CHECK(d.pounder.height == c.pounder.height);
  CHECK(d.contact.decay == c.contact.decay);
  CHECK(d.backfill.mode == c.backfill.mode);
  REQUIRE(d.tracers.size() == 2);
  CHECK(d.tracers[1].name == c.tracers[1].name);
  CHECK(d.tracers[1].r == c.tracers[1].r);

  const std::string pounder = "[pounder]\nmass = 10\nbase_diameter = 0.09\nmax_diameter = 0.1\nheight = 0.2\n";
  Parts p;
  p.rest = "[schedule]\ndrop_heights = [0.3, -0.5]\n" + pounder;
  require_error(p.text(), {"deck.toml", "schedule.drop_heights[1]", "-0.5", "out of range", "value > 0"});
  p.rest = "[schedule]\ndrop_heights = [0.3, 0.5]\nbackfill_after = [2, 1]\n" + pounder;
  require_error(p.text(), {"schedule.backfill_after[1]", "increasing"});
  p.rest = "[schedule]\ndrop_heights = [0.3, 0.5]\nbackfill_after = [3]\n" + pounder;
  require_error(p.text(), {"schedule.backfill_after[0]", "<= 2"});
  p.rest = "[schedule]\ndrop_heights = [0.3]\nbackfill_after = [1]\n" + pounder;
  require_error(p.text(), {"schedule.backfill_after", "[backfill]"});
  p.rest = "[schedule]\ndrop_heights = [0.3]\n";
  require_error(p.text(), {"pounder", "missing", "mass"});
  p.rest = pounder;
  require_error(p.text(), {"pounder", "only used with a [schedule]"});
  p.rest = "[schedule]\ndrop_heights = [0.3]\n" + pounder + "profile_segment = 3\n";
  require_error(p.text(), {"pounder.profile_segment", "not a known key", "profile_segments"});
  p.rest = "[contact]\nstatic_friction = 0.3\ndynamic_friction = 0.4\n";
  require_error(p.text(), {"contact.dynamic_friction", "0.4", "dynamic_friction <= static_friction"});
  p.rest = "[backfill]\nmaterial = \"gravel\"\n";
  require_error(p.text(), {"backfill.material", "gravel", "not a known material"});
  p.rest = "[[tracers]]\nname = \"a,b\"\nr = 0\nz = 0\n";
  require_error(p.text(), {"tracers[0].name", "without commas"});
}

TEST_CASE("Deck: [fem] parses, validates and round-trips", "[deck][fem]") {
  Parts p;
  p.rest = "[fem]\nelement_size = 0.02\ngrading = 1.1\nsph_zone = { r = [0, 0.3], z = [0.5, 1.0] }\n";
  const Config c = parse_deck(p.text(), "deck.toml");
  CHECK(c.fem.enabled);
  CHECK(c.fem.element_size == 0.02);
  CHECK(c.fem.grading == 1.1);
  CHECK(c.fem.zone_r_max == 0.3);
  CHECK(c.fem.zone_z_min == 0.5);
  CHECK(c.fem.hourglass == "viscous");  // the default with a tie (docs/coupling.md)
  const Config back = parse_deck(tamp::to_toml(c), "deck.toml");
  CHECK(back.fem.enabled);
  CHECK(back.fem.grading == 1.1);
  CHECK(back.fem.zone_z_max == 1.0);
  CHECK(back.fem.hourglass == "viscous");
  // the deck switch: off leaves everything in particles
  Parts off = p;
  off.rest = "[fem]\nenabled = false\nsph_zone = { r = [0, 0.3], z = [0.5, 1.0] }\n";
  const Config c_off = parse_deck(off.text(), "deck.toml");
  CHECK_FALSE(c_off.fem.enabled);
  // Switched off, the elements' size is not held to the tie limits (it is unused): a finer
  // or coarser spacing set on an all-particle deck is not refused over it; switched on, it is.
  off.rest = "[fem]\nenabled = false\nelement_size = 0.005\nsph_zone = { r = [0, 0.3], z = [0.5, 1.0] }\n";
  CHECK(parse_deck(off.text(), "deck.toml").fem.element_size == 0.005);
  CHECK_THROWS_AS(parse_deck(off.text(), "deck.toml", {"fem.enabled=true"}), DeckError);
  off.rest = "[fem]\nenabled = false\nelement_size = -1\nsph_zone = { r = [0, 0.3], z = [0.5, 1.0] }\n";
  require_error(off.text(), {"fem.element_size", "-1"});
  // errors name the file, the key, the value and what is allowed
  Parts bad = p;
  bad.rest = "[fem]\nhourglass = \"stiff\"\nsph_zone = { r = [0, 0.3], z = [0.5, 1.0] }\n";
  require_error(bad.text(), {"fem.hourglass", "stiff", "viscous", "stiffness"});
  bad.rest = "[fem]\nelement_size = 0.005\nsph_zone = { r = [0, 0.3], z = [0.5, 1.0] }\n";
  require_error(bad.text(), {"fem.element_size", "0.005", "sph.spacing"});
  bad.rest = "[fem]\nelement_size = 0.04\nsph_zone = { r = [0, 0.3], z = [0.5, 1.0] }\n";
  require_error(bad.text(), {"fem.element_size", "0.04", "2 sph.spacing", "unstable"});
  bad.rest = "[fem]\nsph_zone = { r = [0, 0.305], z = [0.5, 1.0] }\n";
  require_error(bad.text(), {"fem.sph_zone.r", "whole particle spacings"});
  bad.rest = "[fem]\nelement_size = 0.02\n";
  require_error(bad.text(), {"fem.sph_zone", "r = [r_min, r_max]"});
  bad.rest = "[fem]\ngrading = 2\nsph_zone = { r = [0, 0.3], z = [0.5, 1.0] }\n";
  require_error(bad.text(), {"fem.grading", "2"});
}

TEST_CASE("Deck: a model that cannot run is refused, naming the key", "[deck]") {
  // Issue 13's reproducers 1, 3 and 4: each was accepted (or crashed the generator).
  SECTION("1e11 particles: counted in 64 bits") {
    Parts p;
    p.sph = "[sph]\nspacing = 1e-6\n";
    p.blocks = "[[blocks]]\nmaterial = \"soil\"\nr = [0, 0.3]\nz = [0, 0.5]\n";
    require_error(p.text(), {"sph.spacing = 1e-06", "1.5e+11 particles", "at most 1e+09"});
  }
  SECTION("a count that wraps a 32-bit int to 65 536") {
    Parts p;
    p.sph = "[sph]\nspacing = 1e-5\n";
    p.blocks = "[[blocks]]\nmaterial = \"soil\"\nr = [0, 0.65536]\nz = [0, 0.65537]\n";
    require_error(p.text(), {"sph.spacing = 1e-05", "4.3e+09 particles"});
  }
  SECTION("an infinite wave speed from G") {
    Parts p;
    p.materials = "[[materials]]\nname = \"soil\"\nmodel = \"elastic\"\ndensity = 2000\nG = 1e308\nnu = 0.3\n";
    require_error(p.text(), {"materials[0].G = 1e+308", "P-wave speed", "inf"});
  }
  SECTION("a zero density from a denormal unit weight") {
    Parts p;
    p.materials = "[[materials]]\nname = \"soil\"\nmodel = \"elastic\"\nunit_weight = 5e-324\nG = 1e6\nnu = 0.3\n";
    require_error(p.text(), {"materials[0].unit_weight = 5e-324", "density 0 kg/m3"});
  }
  SECTION("a zero stable step from the CFL number") {
    Parts p;
    p.top = "[run]\ncfl = 5e-324\n";
    require_error(p.text(), {"run.cfl = 5e-324", "stable step of 0 s"});
  }
  SECTION("a block thinner than one spacing") {
    Parts p;
    p.blocks = "[[blocks]]\nmaterial = \"soil\"\nr = [0.0, 1e-6]\nz = [0, 1]\n";
    require_error(p.text(), {"blocks[0].r = [0.0, 1e-06]", "thinner than one particle spacing"});
  }
}

TEST_CASE("Deck: errors name the right key and print the value readably", "[deck]") {
  // Issue 13's reproducer 5.
  SECTION("an SPH zone edge off the particle grid in z blames z, not r") {
    Parts p;
    p.rest = "[fem]\nsph_zone = { r = [0.0, 0.30], z = [0.4, 0.795] }\n";
    require_error(p.text(), {"fem.sph_zone.z = [0.4, 0.795]", "whole particle spacings"});
  }
  SECTION("a huge block is out of range, printed short") {
    Parts p;
    p.blocks = "[[blocks]]\nmaterial = \"soil\"\nr = [0, 1e308]\nz = [0, 1]\n";
    const std::string msg = require_error(p.text(), {"blocks[0].r = [0, 1e+308] is out of range", "<= 1e4"});
    CHECK(msg.size() < 200);
  }
  SECTION("a file name with a newline stays on one line") {
    Parts p;
    p.top = "gravity = -1\n";
    std::string msg;
    try {
      parse_deck(p.text(), "odd\nname.toml");
    } catch (const DeckError& e) {
      msg = e.what();
    }
    CHECK(msg.find('\n') == std::string::npos);
    CHECK_THAT(msg, Catch::StartsWith("odd\\x0aname.toml: gravity = -1 is out of range"));
  }
}

TEST_CASE("Deck: --set overrides land where the deck would put them and are validated there", "[deck][cli]") {
  // Values of every TOML kind, a table path, a new table, an inline table, a material by name.
  const Config c = parse_deck(kValidDeck, "valid.toml",
                              {"sph.spacing=0.0025", "sph.kernel_correction=true", "run.name=\"set\"", "gravity=9.81",
                               "clay.Su=12000", "sand.phi_deg=33", "boundaries.bottom.type=\"roller\"",
                               "contact.decay=5"});
  CHECK(c.sph.spacing == 0.0025);
  CHECK(c.sph.kernel_correction == true);
  CHECK(c.run.name == "set");
  CHECK(c.gravity == 9.81);
  CHECK(c.materials[1].cohesion == 12000.0);
  CHECK(c.materials[0].phi_deg == 33.0);
  CHECK(c.bottom.type == WallType::Roller);
  CHECK(c.contact.decay == 5.0);
  CHECK(c.sph.h_factor == 1.5);  // the rest as written

  // A refused setting: exit code 2 in the program (DeckError), naming the deck, the setting
  // and what is allowed.
  auto error_of = [](const std::vector<std::string>& sets) {
    try {
      parse_deck(kValidDeck, "deck.toml", sets);
    } catch (const DeckError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string value = error_of({"sph.spacing=abc"});
  CHECK(value.find("deck.toml: --set 'sph.spacing=abc': the value 'abc' is not a TOML value") == 0);
  CHECK(error_of({"sph.spacing=1e999"}).find("is not a TOML value") != std::string::npos);
  CHECK(error_of({"sph.spacing"}).find("expected KEY=VALUE") != std::string::npos);
  CHECK(error_of({"sph..spacing=1"}).find("has an empty part") != std::string::npos);
  CHECK(error_of({"gravity.x=1"}).find("'gravity' is a float in the deck, not a table") != std::string::npos);
  CHECK(error_of({"sph.spacing=1\nx = 2"}).find("is not a TOML value") != std::string::npos);
  // Checked by the deck's own rules, with the settings named.
  const std::string range = error_of({"sph.spacing=-1"});
  CHECK(range.find("deck.toml: sph.spacing = -1 is out of range") == 0);
  CHECK(range.find("(with --set sph.spacing=-1)") != std::string::npos);
  CHECK(error_of({"sph.kernel_correction=3"}).find("has the wrong type") != std::string::npos);
  CHECK(error_of({"clay.bogus=1"}).find("materials[1].bogus = 1 is not a known key") != std::string::npos);
  CHECK(error_of({"nosuch.key=1"}).find("is not a known key") != std::string::npos);

  // KEY= removes the key: a material's model switched by hand, its old keys removed and the
  // new model's added; removing a key the new model needs, or one the deck lacks, is refused.
  CHECK(error_of({"clay.model=\"modified-cam-clay\""}).find("].Su = 20000.0 is not used by model") != std::string::npos);
  const Config mcc = parse_deck(kValidDeck, "valid.toml",
                                {"clay.model=\"modified-cam-clay\"", "clay.Su=", "clay.lambda=0.2", "clay.kappa=0.04",
                                 "clay.M=0.9", "clay.v0=2.2", "clay.p_c0=45000"});
  CHECK(mcc.materials[1].model == "modified-cam-clay");
  CHECK(error_of({"clay.Su="}).find("Su") != std::string::npos);  // Tresca needs it
  CHECK(error_of({"clay.Su="}).find("(with --set clay.Su=)") != std::string::npos);
  CHECK(error_of({"clay.bogus="}) == "deck.toml: --set 'clay.bogus=': the deck has no 'clay.bogus' to remove");
  CHECK(error_of({"nosuch.key="}) == "deck.toml: --set 'nosuch.key=': the deck has no 'nosuch.key' to remove");
}
