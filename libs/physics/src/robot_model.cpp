#include "physics/robot_model.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>

namespace doppel::physics {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Eigen::Vector3d vec(const proto::Vector3& v) { return {v.x(), v.y(), v.z()}; }

Eigen::Isometry3d pose(const proto::Pose& p) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = rotation_from_rpy_deg(p.rpy_deg().x(), p.rpy_deg().y(), p.rpy_deg().z());
  X.translation() = vec(p.position_m());
  return X;
}

// Volume, and the inertia about the shape's own centre per unit mass, in the shape frame.
struct UnitMass {
  double volume_m3 = 0.0;
  Eigen::Matrix3d inertia_per_kg = Eigen::Matrix3d::Zero();  // about `centre`
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();          // centre of volume in the shape frame
};

UnitMass unit_mass(const ShapeSpec& shape) {
  const Eigen::Vector3d& s = shape.size_m;
  UnitMass u;
  switch (shape.type) {
    case ShapeType::kBox:
      u.volume_m3 = s.x() * s.y() * s.z();
      u.inertia_per_kg.diagonal() << (s.y() * s.y() + s.z() * s.z()) / 12.0, (s.x() * s.x() + s.z() * s.z()) / 12.0,
          (s.x() * s.x() + s.y() * s.y()) / 12.0;
      break;
    case ShapeType::kSphere:
      u.volume_m3 = 4.0 / 3.0 * std::numbers::pi * std::pow(s.x(), 3);
      u.inertia_per_kg.diagonal().setConstant(0.4 * s.x() * s.x());
      break;
    case ShapeType::kCylinder: {
      const double r = s.x(), l = s.y();
      u.volume_m3 = std::numbers::pi * r * r * l;
      const double lateral = (3.0 * r * r + l * l) / 12.0;
      u.inertia_per_kg.diagonal() << lateral, lateral, 0.5 * r * r;
      break;
    }
    case ShapeType::kCapsule: {
      const double r = s.x(), l = s.y();
      const double v_cyl = std::numbers::pi * r * r * l;
      const double v_caps = 4.0 / 3.0 * std::numbers::pi * r * r * r;
      u.volume_m3 = v_cyl + v_caps;
      const double f_cyl = v_cyl / u.volume_m3, f_caps = v_caps / u.volume_m3;
      const double axial = f_cyl * 0.5 * r * r + f_caps * 0.4 * r * r;
      const double lateral = f_cyl * (l * l / 12.0 + r * r / 4.0) + f_caps * (0.4 * r * r + l * l / 4.0 + 3.0 * l * r / 8.0);
      u.inertia_per_kg.diagonal() << lateral, lateral, axial;
      break;
    }
    case ShapeType::kConvex:
      u.volume_m3 = shape.hull->volume_m3;
      u.inertia_per_kg = shape.hull->inertia_per_kg;
      u.centre = shape.hull->centroid;
      break;
    case ShapeType::kRing:
      break;
  }
  return u;
}

// A shape's bounding box in its own frame: half extents (boxes exactly, round shapes enclosed).
Eigen::Vector3d half_extents(const ShapeSpec& s) {
  switch (s.type) {
    case ShapeType::kBox:
      return 0.5 * s.size_m;
    case ShapeType::kSphere:
      return Eigen::Vector3d::Constant(s.size_m.x());
    case ShapeType::kCylinder:
      return {s.size_m.x(), s.size_m.x(), 0.5 * s.size_m.y()};
    case ShapeType::kCapsule:
      return {s.size_m.x(), s.size_m.x(), 0.5 * s.size_m.y() + s.size_m.x()};
    case ShapeType::kConvex:
      return s.size_m;
    case ShapeType::kRing:
      break;
  }
  return Eigen::Vector3d::Zero();
}

// Separating-axis test of two oriented boxes (centre, axes as columns, half extents), each grown by
// `margin` on every side.
bool boxes_overlap(const Eigen::Isometry3d& X_A, const Eigen::Vector3d& half_A, const Eigen::Isometry3d& X_B,
                   const Eigen::Vector3d& half_B, double margin) {
  const Eigen::Vector3d a = half_A.array() + margin;
  const Eigen::Vector3d b = half_B.array() + margin;
  const Eigen::Matrix3d R = X_A.linear().transpose() * X_B.linear();  // B's axes in A
  const Eigen::Vector3d t = X_A.linear().transpose() * (X_B.translation() - X_A.translation());
  const Eigen::Matrix3d absR = R.cwiseAbs().array() + 1e-12;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(t(i)) > a(i) + absR.row(i).dot(b)) return false;
  }
  for (int j = 0; j < 3; ++j) {
    if (std::abs(t.dot(R.col(j))) > absR.col(j).dot(a) + b(j)) return false;
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const double distance = std::abs(t(i2) * R(i1, j) - t(i1) * R(i2, j));
      const double reach = a(i1) * absR(i2, j) + a(i2) * absR(i1, j) + b(j1) * absR(i, j2) + b(j2) * absR(i, j1);
      if (distance > reach) return false;
    }
  }
  return true;
}

// Body pairs exempt from self-collision (see RobotModel::collision_exempt).
std::vector<std::pair<int, int>> exempt_pairs(const RobotModel& model) {
  constexpr double kTouchMargin_m = 0.001;  // per side: parts closer than 2 mm count as touching
  std::set<std::pair<int, int>> pairs;
  for (const LinkModel& link : model.links) {
    pairs.emplace(std::min(link.parent, link.child), std::max(link.parent, link.child));
  }
  std::vector<double> q;
  for (const LinkModel& link : model.links) q.push_back(link.initial);
  const std::vector<Eigen::Isometry3d> X_RB = body_poses(model, q);
  const auto n = static_cast<int>(model.bodies.size());
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      if (pairs.count({a, b}) != 0U) continue;
      bool touching = false;
      for (const ShapeSpec& sa : model.bodies[static_cast<size_t>(a)].shapes) {
        for (const ShapeSpec& sb : model.bodies[static_cast<size_t>(b)].shapes) {
          touching = touching || boxes_overlap(X_RB[static_cast<size_t>(a)] * sa.X_BS, half_extents(sa),
                                               X_RB[static_cast<size_t>(b)] * sb.X_BS, half_extents(sb), kTouchMargin_m);
        }
      }
      if (touching) pairs.emplace(a, b);
    }
  }
  return {pairs.begin(), pairs.end()};
}

class Compiler {
 public:
  Compiler(const proto::RobotFile& file, const MotorCatalog& motors)
      : file_(file), motors_(motors), description_(file.description()), figure_(description_.figure()) {}

  RobotModel run() {
    model_.name = description_.name();
    model_.source = file_.path();
    if (!description_.has_figure() || figure_.body_size() == 0) {
      file_.fail(description_, "figure", -1, "the robot has no body: add a figure with at least one body");
    }
    read_materials();
    read_bodies();
    read_links();
    read_sensors();
    model_.self_collision = !figure_.has_self_collision() || figure_.self_collision();
    model_.collision_exempt = exempt_pairs(model_);
    return std::move(model_);
  }

 private:
  [[noreturn]] void fail(const google::protobuf::Message& m, std::string_view field, int index, const std::string& what) const {
    file_.fail(m, field, index, what);
  }

  void read_materials() {
    materials_["default"] = MaterialSpec{};
    for (int i = 0; i < figure_.material_size(); ++i) {
      const proto::Material& m = figure_.material(i);
      if (m.name().empty()) {
        fail(m, "name", -1, "a material needs a name");
      }
      if (materials_.count(m.name()) != 0U && m.name() != "default") {
        fail(m, "name", -1, "material '" + m.name() + "' is defined twice");
      }
      if (!(m.friction() >= 0.0)) {
        fail(m, "friction", -1, "friction must be >= 0");
      }
      if (!(m.restitution() >= 0.0 && m.restitution() <= 1.0)) {
        fail(m, "restitution", -1, "restitution must be within 0..1");
      }
      materials_[m.name()] = MaterialSpec{m.friction(), m.restitution()};
    }
  }

  // Explicit mass properties: mass, centre of mass in D, inertia about it in D's axes.
  void read_inertial(const proto::Inertial& in, double* mass, Eigen::Vector3d* com, Eigen::Matrix3d* inertia) const {
    if (!(in.mass_kg() > 0.0) || !std::isfinite(in.mass_kg())) {
      fail(in, "mass_kg", -1, "mass must be > 0");
    }
    Eigen::Matrix3d I;
    I << in.ixx_kg_m2(), in.ixy_kg_m2(), in.ixz_kg_m2(), in.ixy_kg_m2(), in.iyy_kg_m2(), in.iyz_kg_m2(),
        in.ixz_kg_m2(), in.iyz_kg_m2(), in.izz_kg_m2();
    if (!I.allFinite()) {
      fail(in, "ixx_kg_m2", -1, "inertia must be finite");
    }
    const Eigen::Vector3d moments = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I).eigenvalues();
    if (!(moments.minCoeff() > 0.0)) {
      fail(in, "ixx_kg_m2", -1, "inertia tensor must be positive definite (principal moments " +
                                    std::to_string(moments.x()) + ", " + std::to_string(moments.y()) + ", " +
                                    std::to_string(moments.z()) + " kg m^2)");
    }
    // A physical body: each principal moment is at most the sum of the other two (1e-6 tolerance
    // for rounded figures).
    if (moments.z() > (moments.x() + moments.y()) * (1.0 + 1e-6)) {
      fail(in, "ixx_kg_m2", -1, "inertia violates the triangle inequality (principal moments " +
                                    std::to_string(moments.x()) + ", " + std::to_string(moments.y()) + ", " +
                                    std::to_string(moments.z()) + " kg m^2): no rigid body has it");
    }
    const Eigen::Isometry3d X_DI = pose(in.origin());
    *mass = in.mass_kg();
    *com = X_DI.translation();
    *inertia = X_DI.linear() * I * X_DI.linear().transpose();
  }

  ShapeSpec read_shape(const proto::Shape& s) {
    ShapeSpec shape;
    shape.X_BS = pose(s.pose());
    auto positive = [&](const google::protobuf::Message& m, std::string_view field, double value) {
      if (!(value > 0.0) || !std::isfinite(value)) {
        fail(m, field, -1, "must be > 0 (got " + std::to_string(value) + ")");
      }
    };
    switch (s.geometry_case()) {
      case proto::Shape::kBox:
        shape.type = ShapeType::kBox;
        shape.size_m = vec(s.box().size_m());
        positive(s.box(), "size_m", shape.size_m.minCoeff());
        break;
      case proto::Shape::kSphere:
        shape.type = ShapeType::kSphere;
        positive(s.sphere(), "radius_m", s.sphere().radius_m());
        shape.size_m = {s.sphere().radius_m(), 0.0, 0.0};
        break;
      case proto::Shape::kCylinder:
        shape.type = ShapeType::kCylinder;
        positive(s.cylinder(), "radius_m", s.cylinder().radius_m());
        positive(s.cylinder(), "length_m", s.cylinder().length_m());
        shape.size_m = {s.cylinder().radius_m(), s.cylinder().length_m(), 0.0};
        break;
      case proto::Shape::kCapsule:
        shape.type = ShapeType::kCapsule;
        positive(s.capsule(), "radius_m", s.capsule().radius_m());
        positive(s.capsule(), "length_m", s.capsule().length_m());
        shape.size_m = {s.capsule().radius_m(), s.capsule().length_m(), 0.0};
        break;
      case proto::Shape::kConvex: {
        shape.type = ShapeType::kConvex;
        std::vector<Eigen::Vector3d> points;
        points.reserve(static_cast<size_t>(s.convex().point_m_size()));
        for (const proto::Vector3& p : s.convex().point_m()) points.push_back(vec(p));
        try {
          shape.hull = convex_hull(points);
        } catch (const std::invalid_argument& e) {
          fail(s.convex(), "point_m", -1, std::string("no convex hull: ") + e.what());
        }
        shape.size_m = shape.hull->half_extents;
        break;
      }
      case proto::Shape::GEOMETRY_NOT_SET:
        fail(s, "box", -1, "a shape needs a geometry: box, sphere, cylinder, capsule or convex");
    }
    return shape;
  }

  void read_bodies() {
    for (int i = 0; i < figure_.body_size(); ++i) {
      const proto::Body& b = figure_.body(i);
      if (b.name().empty()) {
        fail(figure_, "body", i, "a body needs a name");
      }
      if (!body_index_.emplace(b.name(), i).second) {
        fail(b, "name", -1, "body '" + b.name() + "' is defined twice");
      }
      if (b.shape_size() == 0 && !b.has_inertial()) {
        fail(b, "name", -1, "body '" + b.name() + "' has no shape (only a body with an inertial may have none)");
      }
      if (b.has_inertial() && (b.has_mass_kg() || b.has_density_kg_m3())) {
        fail(b, "inertial", -1, "give inertial, mass_kg or density_kg_m3, only one of them");
      }
      if (!b.has_inertial() && b.has_mass_kg() == b.has_density_kg_m3()) {
        fail(b, b.has_mass_kg() ? "density_kg_m3" : "mass_kg", -1,
             b.has_mass_kg() ? "give mass_kg or density_kg_m3, not both"
                             : "missing mass: body '" + b.name() + "' needs mass_kg, density_kg_m3 or inertial");
      }
      if (b.has_mass_kg() && !(b.mass_kg() > 0.0)) {
        fail(b, "mass_kg", -1, "mass must be > 0");
      }
      if (b.has_density_kg_m3() && !(b.density_kg_m3() > 0.0)) {
        fail(b, "density_kg_m3", -1, "density must be > 0");
      }
      const std::string material = b.material().empty() ? "default" : b.material();
      auto found = materials_.find(material);
      if (found == materials_.end()) {
        fail(b, "material", -1, "unknown material '" + material + "'");
      }
      if (b.color().r() > 255 || b.color().g() > 255 || b.color().b() > 255) {
        fail(b, "color", -1, "colour components are 0..255");
      }

      BodyModel body;
      body.name = b.name();
      body.material = found->second;
      body.colour = Rgb{static_cast<uint8_t>(b.color().r()), static_cast<uint8_t>(b.color().g()),
                        static_cast<uint8_t>(b.color().b())};
      std::vector<ShapeSpec> shapes_D;
      double volume = 0.0;
      for (int s = 0; s < b.shape_size(); ++s) {
        shapes_D.push_back(read_shape(b.shape(s)));
        volume += unit_mass(shapes_D.back()).volume_m3;
      }
      // Centre of mass and inertia in D, then the principal frame B.
      Eigen::Vector3d com = Eigen::Vector3d::Zero();
      Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
      if (b.has_inertial()) {
        read_inertial(b.inertial(), &body.mass_kg, &com, &inertia);
      } else {
        body.mass_kg = b.has_mass_kg() ? b.mass_kg() : b.density_kg_m3() * volume;
        const double density = body.mass_kg / volume;
        for (const ShapeSpec& s : shapes_D) {
          com += density * unit_mass(s).volume_m3 * (s.X_BS * unit_mass(s).centre);
        }
        com /= body.mass_kg;
        for (const ShapeSpec& s : shapes_D) {
          const UnitMass u = unit_mass(s);
          const double m = density * u.volume_m3;
          const Eigen::Matrix3d R = s.X_BS.linear();
          const Eigen::Vector3d d = s.X_BS * u.centre - com;
          inertia += m * (R * u.inertia_per_kg * R.transpose());
          inertia += m * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
        }
      }
      Eigen::Matrix3d R_DB = Eigen::Matrix3d::Identity();
      const double off_diagonal = std::abs(inertia(0, 1)) + std::abs(inertia(0, 2)) + std::abs(inertia(1, 2));
      if (off_diagonal > 1e-12 * inertia.trace()) {
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(inertia);
        R_DB = solver.eigenvectors();
        if (R_DB.determinant() < 0.0) {
          R_DB.col(2) = -R_DB.col(2);
        }
      }
      body.inertia_kg_m2 = (R_DB.transpose() * inertia * R_DB).diagonal();
      Eigen::Isometry3d X_DB = Eigen::Isometry3d::Identity();
      X_DB.linear() = R_DB;
      X_DB.translation() = com;
      body.X_BD = X_DB.inverse();
      body.X_RB = pose(b.pose()) * X_DB;
      for (ShapeSpec& s : shapes_D) {
        s.X_BS = body.X_BD * s.X_BS;
        body.shapes.push_back(s);
      }
      model_.mass_kg += body.mass_kg;
      model_.bodies.push_back(std::move(body));
    }
  }

  int body_ref(const google::protobuf::Message& m, std::string_view field, const std::string& name) const {
    auto found = body_index_.find(name);
    if (found == body_index_.end()) {
      fail(m, field, -1, name.empty() ? std::string("no body given") : "unknown body '" + name + "'");
    }
    return found->second;
  }

  // The bus device (bus index, id) of the description, or a failure naming `m`.
  const proto::Device& device_ref(const google::protobuf::Message& m, uint32_t bus, uint32_t id) const {
    if (bus >= static_cast<uint32_t>(description_.bus_size())) {
      fail(m, "bus", -1, "bus " + std::to_string(bus) + " does not exist (the robot has " +
                              std::to_string(description_.bus_size()) + " bus(es))");
    }
    for (const proto::Device& d : description_.bus(static_cast<int>(bus)).device()) {
      if (d.id() == id) {
        return d;
      }
    }
    fail(m, "id", -1, "no device with ID " + std::to_string(id) + " on bus " + std::to_string(bus));
  }

  void read_links() {
    const int n = figure_.body_size();
    std::vector<int> parent_link(static_cast<size_t>(n), -1);
    std::map<std::string, int> link_names;
    std::map<std::pair<uint32_t, uint32_t>, int> motor_owner;
    std::vector<LinkModel> links;
    for (int i = 0; i < figure_.link_size(); ++i) {
      const proto::Link& l = figure_.link(i);
      if (l.name().empty()) {
        fail(figure_, "link", i, "a link needs a name");
      }
      if (!link_names.emplace(l.name(), i).second) {
        fail(l, "name", -1, "link '" + l.name() + "' is defined twice");
      }
      LinkModel link;
      link.name = l.name();
      switch (l.type()) {
        case proto::LINK_REVOLUTE: link.type = JointType::kRevolute; break;
        case proto::LINK_PRISMATIC: link.type = JointType::kPrismatic; break;
        case proto::LINK_SPHERICAL: link.type = JointType::kSpherical; break;
        case proto::LINK_FIXED: link.type = JointType::kFixed; break;
        default: fail(l, "type", -1, "link type missing: LINK_REVOLUTE, LINK_PRISMATIC, LINK_SPHERICAL or LINK_FIXED");
      }
      link.parent = body_ref(l, "parent", l.parent());
      link.child = body_ref(l, "child", l.child());
      if (link.parent == link.child) {
        fail(l, "child", -1, "a link cannot join body '" + l.child() + "' to itself");
      }
      const int previous = parent_link[static_cast<size_t>(link.child)];
      if (previous >= 0) {
        fail(l, "child", -1,
             "link would close a loop: body '" + l.child() + "' is already the child of link '" +
                 figure_.link(previous).name() + "' (a tree of " + std::to_string(n) + " bodies has " +
                 std::to_string(n - 1) + " links, each body the child of at most one)");
      }
      parent_link[static_cast<size_t>(link.child)] = i;
      link.anchor_R = vec(l.anchor_m());
      link.axis_R = vec(l.axis());
      const bool needs_axis = link.type == JointType::kRevolute || link.type == JointType::kPrismatic;
      if (needs_axis) {
        if (!(link.axis_R.norm() > 1e-9)) {
          fail(l, "axis", -1, "a revolute or prismatic link needs a non-zero axis");
        }
        link.axis_R.normalize();
      } else {
        link.axis_R = Eigen::Vector3d::UnitZ();  // unused by the joint; keeps joint frames well defined
      }
      const bool revolute = link.type == JointType::kRevolute;
      const bool has_deg = l.has_lower_deg() || l.has_upper_deg();
      const bool has_m = l.has_lower_m() || l.has_upper_m();
      if (has_deg && !revolute) {
        fail(l, l.has_lower_deg() ? "lower_deg" : "upper_deg", -1, "angle limits apply to revolute links only");
      }
      if (has_m && link.type != JointType::kPrismatic) {
        fail(l, l.has_lower_m() ? "lower_m" : "upper_m", -1, "length limits apply to prismatic links only");
      }
      if (has_deg || has_m) {
        const bool both = revolute ? (l.has_lower_deg() && l.has_upper_deg()) : (l.has_lower_m() && l.has_upper_m());
        if (!both) {
          fail(l, revolute ? "upper_deg" : "upper_m", -1, "give both limits or neither");
        }
        link.limited = true;
        link.lower = revolute ? l.lower_deg() * kDeg : l.lower_m();
        link.upper = revolute ? l.upper_deg() * kDeg : l.upper_m();
        if (!(link.lower <= link.upper)) {
          fail(l, revolute ? "upper_deg" : "upper_m", -1, "upper limit below lower limit");
        }
        if (revolute && (link.lower < -std::numbers::pi || link.upper > std::numbers::pi)) {
          fail(l, "lower_deg", -1, "revolute limits must lie within -180..180 deg");
        }
      }
      link.initial = revolute ? l.initial_deg() * kDeg : l.initial_m();
      if ((l.initial_deg() != 0.0 && !revolute) || (l.initial_m() != 0.0 && link.type != JointType::kPrismatic)) {
        fail(l, revolute ? "initial_m" : "initial_deg", -1, "initial position of the wrong unit for this link type");
      }
      if (link.limited && (link.initial < link.lower - 1e-12 || link.initial > link.upper + 1e-12)) {
        fail(l, revolute ? "initial_deg" : "initial_m", -1, "initial position outside the link's limits");
      }
      if (l.has_motor()) {
        const proto::Motor& m = l.motor();
        if (!revolute) {
          fail(l, "motor", -1, "only revolute links can carry a servo motor");
        }
        const proto::Device& device = device_ref(m, m.bus(), m.id());
        const auto key = std::make_pair(m.bus(), m.id());
        auto [owner, fresh] = motor_owner.emplace(key, i);
        if (!fresh) {
          fail(m, "id", -1, "motor ID " + std::to_string(m.id()) + " on bus " + std::to_string(m.bus()) +
                                " is used twice (already driven by link '" + figure_.link(owner->second).name() + "')");
        }
        if (!m.model().empty() && m.model() != device.model()) {
          fail(m, "model", -1, "model '" + m.model() + "' does not match the bus device ID " + std::to_string(m.id()) +
                                   " ('" + device.model() + "')");
        }
        std::optional<DcMotorParams> params = motors_ ? motors_(device.model(), 0) : std::nullopt;
        if (!params) {
          fail(m, "id", -1, "bus device ID " + std::to_string(m.id()) + " is a '" + device.model() +
                                "', not a servo with known motor constants");
        }
        const proto::MotorFriction friction = m.has_friction() ? m.friction() : figure_.motor_friction();
        if (friction != proto::FRICTION_DEFAULT) {
          params = motors_(device.model(), static_cast<int>(friction));
          if (!params) {
            const std::string name = proto::MotorFriction_Name(friction);
            fail(m, "friction", -1, "'" + (name.empty() ? std::to_string(static_cast<int>(friction)) : name) + "' needs BAM's identification of the servo, which covers MX-64 and MX-106 only; bus device ID " + std::to_string(m.id()) + " is a '" + device.model() + "'");
          }
        }
        if (m.has_back_emf_v_s_rad()) params->back_emf_v_s_rad = m.back_emf_v_s_rad();
        if (m.has_resistance_ohm()) params->resistance_ohm = m.resistance_ohm();
        if (m.has_torque_constant_nm_a()) params->torque_constant_nm_a = m.torque_constant_nm_a();
        if (!(params->back_emf_v_s_rad > 0.0 && params->resistance_ohm > 0.0 && params->torque_constant_nm_a > 0.0)) {
          fail(m, "resistance_ohm", -1, "motor constants must be > 0");
        }
        MotorModel motor;
        motor.bus = m.bus();
        motor.id = static_cast<uint8_t>(m.id());
        motor.model = device.model();
        motor.params = *params;
        motor.direction = m.reversed() ? -1.0 : 1.0;
        motor.offset_rad = m.offset_deg() * kDeg;
        const proto::Bus& bus = description_.bus(static_cast<int>(m.bus()));
        if (bus.has_supply_voltage_v()) {
          if (!(bus.supply_voltage_v() > 0.0 && bus.supply_voltage_v() <= 30.0)) {
            file_.fail(bus, "supply_voltage_v", -1, "must be in (0, 30] V");
          }
          motor.supply_voltage_v = bus.supply_voltage_v();
        }
        link.motor = static_cast<int>(model_.motors.size());
        model_.motors.push_back(std::move(motor));
      }
      links.push_back(std::move(link));
    }

    // One root, every body reachable from it.
    int root = -1;
    for (int b = 0; b < n; ++b) {
      if (parent_link[static_cast<size_t>(b)] < 0) {
        if (root >= 0) {
          fail(figure_.body(b), "name", -1,
               "body '" + figure_.body(b).name() + "' is not connected: it is no link's child, and neither is '" +
                   figure_.body(root).name() + "' (a tree of " + std::to_string(n) + " bodies has one root and " +
                   std::to_string(n - 1) + " links)");
        }
        root = b;
      }
    }
    if (root < 0) {
      fail(figure_, "link", figure_.link_size() - 1,
           "the links form a loop: every body is some link's child, so there is no root body");
    }
    model_.root = root;
    std::vector<int> order;
    std::vector<int> frontier{root};
    std::vector<bool> reached(static_cast<size_t>(n), false);
    reached[static_cast<size_t>(root)] = true;
    while (!frontier.empty()) {
      std::vector<int> next;
      for (int parent : frontier) {
        for (int i = 0; i < static_cast<int>(links.size()); ++i) {
          if (links[static_cast<size_t>(i)].parent == parent) {
            order.push_back(i);
            reached[static_cast<size_t>(links[static_cast<size_t>(i)].child)] = true;
            next.push_back(links[static_cast<size_t>(i)].child);
          }
        }
      }
      frontier = std::move(next);
    }
    for (int b = 0; b < n; ++b) {
      if (!reached[static_cast<size_t>(b)]) {
        const int l = parent_link[static_cast<size_t>(b)];
        fail(figure_.link(l), "parent", -1,
             "link would close a loop: body '" + figure_.body(b).name() + "' is part of a cycle that is not connected to the root '" +
                 figure_.body(root).name() + "'");
      }
    }
    for (int i : order) {
      LinkModel& link = links[static_cast<size_t>(i)];
      if (link.motor >= 0) {
        model_.motors[static_cast<size_t>(link.motor)].link = static_cast<int>(model_.links.size());
      }
      model_.links.push_back(std::move(link));
    }
  }

  void check_sensor_device(const google::protobuf::Message& m, uint32_t bus, uint32_t id) {
    device_ref(m, bus, id);
    if (!sensor_ids_.emplace(bus, id).second) {
      fail(m, "id", -1, "bus " + std::to_string(bus) + " ID " + std::to_string(id) + " is used by two sensors");
    }
  }

  void read_sensors() {
    for (const proto::Imu& s : figure_.imu()) {
      check_sensor_device(s, s.bus(), s.id());
      model_.imus.push_back(ImuModel{s.name(), body_ref(s, "body", s.body()), pose(s.mount()), s.bus(), static_cast<uint8_t>(s.id())});
    }
    for (const proto::FootSensor& s : figure_.foot()) {
      check_sensor_device(s, s.bus(), s.id());
      FootModel foot;
      foot.name = s.name();
      foot.body = body_ref(s, "body", s.body());
      if (s.cell_m_size() != 4) {
        fail(s, s.cell_m_size() > 0 ? "cell_m" : "body", s.cell_m_size() > 0 ? s.cell_m_size() - 1 : -1,
             "a foot has exactly four load cells (FL, FR, BL, BR), got " + std::to_string(s.cell_m_size()));
      }
      for (int c = 0; c < 4; ++c) {
        foot.cell_D[static_cast<size_t>(c)] = vec(s.cell_m(c));
      }
      foot.bus = s.bus();
      foot.id = static_cast<uint8_t>(s.id());
      model_.feet.push_back(std::move(foot));
    }
    for (const proto::CameraMount& s : figure_.camera()) {
      model_.cameras.push_back(CameraModel{s.name(), body_ref(s, "body", s.body()), pose(s.mount())});
    }
  }

  const proto::RobotFile& file_;
  const MotorCatalog& motors_;
  const proto::RobotDescription& description_;
  const proto::Figure& figure_;
  RobotModel model_;
  std::map<std::string, MaterialSpec> materials_;
  std::map<std::string, int> body_index_;
  std::set<std::pair<uint32_t, uint32_t>> sensor_ids_;
};

}  // namespace

Eigen::Matrix3d rotation_from_rpy_deg(double roll_deg, double pitch_deg, double yaw_deg) {
  return (Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch_deg * kDeg, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

RobotModel compile_robot(const proto::RobotFile& file, const MotorCatalog& motors) {
  return Compiler(file, motors).run();
}

void validate_body(const proto::RobotFile& file, const MotorCatalog& motors) { (void)compile_robot(file, motors); }

std::vector<Eigen::Isometry3d> body_poses(const RobotModel& model, const std::vector<double>& q) {
  if (q.size() != model.links.size()) {
    throw std::invalid_argument("body_poses: " + std::to_string(q.size()) + " positions for " +
                                std::to_string(model.links.size()) + " links");
  }
  std::vector<Eigen::Isometry3d> X(model.bodies.size());
  X[static_cast<size_t>(model.root)] = model.bodies[static_cast<size_t>(model.root)].X_RB;
  for (size_t i = 0; i < model.links.size(); ++i) {
    const LinkModel& link = model.links[i];
    Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
    if (link.type == JointType::kRevolute) {
      motion = Eigen::Translation3d(link.anchor_R) * Eigen::AngleAxisd(q[i], link.axis_R) * Eigen::Translation3d(-link.anchor_R);
    } else if (link.type == JointType::kPrismatic) {
      motion = Eigen::Translation3d(q[i] * link.axis_R);
    }
    const BodyModel& parent = model.bodies[static_cast<size_t>(link.parent)];
    const BodyModel& child = model.bodies[static_cast<size_t>(link.child)];
    X[static_cast<size_t>(link.child)] = X[static_cast<size_t>(link.parent)] * parent.X_RB.inverse() * motion * child.X_RB;
  }
  return X;
}

}  // namespace doppel::physics
