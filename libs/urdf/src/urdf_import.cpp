#include "urdf/urdf_import.h"

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <console_bridge/console.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <assimp/Importer.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "physics/convex_hull.h"

namespace doppel::urdf {
namespace {

namespace fs = std::filesystem;
constexpr double kRadToDeg = 180.0 / std::numbers::pi;
constexpr std::size_t kMaxUrdfBytes = 16 * 1024 * 1024;   // as proto::TextFile::kMaxBytes
constexpr std::uintmax_t kMaxMeshBytes = 256 * 1024 * 1024;  // far above any robot's collision mesh

// Collects urdfdom's console_bridge messages while it parses (and keeps them off stderr).
class Messages : public console_bridge::OutputHandler {
 public:
  Messages() : previous_(console_bridge::getOutputHandler()) { console_bridge::useOutputHandler(this); }
  ~Messages() override { console_bridge::useOutputHandler(previous_); }
  Messages(const Messages&) = delete;
  Messages& operator=(const Messages&) = delete;
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    // urdfdom logs some errors and goes on without the element (an unknown geometry drops its
    // <collision>): any error refuses the file.
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR && text_.size() < 1024) {
      text_ += (text_.empty() ? "" : "; ") + text.substr(0, 512);
    }
  }
  const std::string& text() const { return text_; }

 private:
  console_bridge::OutputHandler* previous_;
  std::string text_;
};

// A name or path from the URDF as messages show it: at most `limit` characters.
std::string shown(const std::string& name, size_t limit = 64) {
  return name.size() <= limit ? name : name.substr(0, limit - 3) + "...";
}

Eigen::Isometry3d iso(const ::urdf::Pose& p) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z).normalized().toRotationMatrix();
  X.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  return X;
}

Eigen::Isometry3d iso(const proto::Pose& p) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  constexpr double d = std::numbers::pi / 180.0;
  X.linear() = (Eigen::AngleAxisd(p.rpy_deg().z() * d, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(p.rpy_deg().y() * d, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(p.rpy_deg().x() * d, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  X.translation() = Eigen::Vector3d(p.position_m().x(), p.position_m().y(), p.position_m().z());
  return X;
}

void set(proto::Vector3* out, const Eigen::Vector3d& v) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

// Pose with R = Rz(yaw) Ry(pitch) Rx(roll), as proto::Pose wants it.
void set(proto::Pose* out, const Eigen::Isometry3d& X) {
  set(out->mutable_position_m(), X.translation());
  const Eigen::Matrix3d& R = X.linear();
  double roll = 0.0, pitch = 0.0, yaw = 0.0;
  if (std::abs(R(2, 0)) < 1.0 - 1e-12) {
    pitch = std::asin(-R(2, 0));
    roll = std::atan2(R(2, 1), R(2, 2));
    yaw = std::atan2(R(1, 0), R(0, 0));
  } else {  // pitch +-90 degrees: roll and yaw turn about the same axis; all of it as yaw
    pitch = R(2, 0) < 0.0 ? std::numbers::pi / 2 : -std::numbers::pi / 2;
    yaw = std::atan2(-R(0, 1), R(1, 1));
  }
  set(out->mutable_rpy_deg(), Eigen::Vector3d(roll, pitch, yaw) * kRadToDeg);
}

std::string joint_kind(const ::urdf::Joint& j) {
  switch (j.type) {
    case ::urdf::Joint::REVOLUTE: return "revolute";
    case ::urdf::Joint::CONTINUOUS: return "continuous";
    case ::urdf::Joint::PRISMATIC: return "prismatic";
    case ::urdf::Joint::FIXED: return "fixed";
    case ::urdf::Joint::FLOATING: return "floating";
    case ::urdf::Joint::PLANAR: return "planar";
    default: return "unknown";
  }
}

bool movable(const ::urdf::Joint& j) {
  return j.type == ::urdf::Joint::REVOLUTE || j.type == ::urdf::Joint::CONTINUOUS || j.type == ::urdf::Joint::PRISMATIC;
}

class Importer {
 public:
  explicit Importer(proto::RobotFile& file)
      : file_(file),
        figure_(*file.mutable_description().mutable_figure()),
        urdf_(figure_.urdf()),
        robot_dir_(fs::path(file.path()).parent_path()) {}

  void run() {
    if (figure_.body_size() > 0 || figure_.link_size() > 0) {
      fail("file", "a figure takes its bodies and links from the URDF or from body / link entries, not both");
    }
    if (urdf_.file().empty()) {
      fail("file", "the URDF file is missing: urdf { file: \"robot.urdf\" ... }");
    }
    urdf_path_ = (robot_dir_ / urdf_.file()).lexically_normal();
    parse();
    index_joint_entries();
    place_links();
    make_bodies();
    make_links();
    move_sensors();
  }

 private:
  // Throws naming the robot file's Urdf field and the URDF file.
  [[noreturn]] void fail(std::string_view field, const std::string& what, int index = -1) const {
    file_.fail(urdf_, field, index, urdf_path_.empty() ? what : urdf_path_.string() + ": " + what);
  }

  std::string where(const std::string& element, const std::string& name) const {
    auto found = lines_.find(element + ":" + name);
    const std::string line = found == lines_.end() ? "" : " (line " + std::to_string(found->second) + ")";
    return element + " '" + shown(name) + "'" + line;
  }

  void parse() {
    // Like proto::TextFile::read: only a regular file of at most 16 MiB (a FIFO would block,
    // /dev/zero never end).
    std::error_code error;
    if (!fs::exists(urdf_path_, error)) {
      fail("file", "cannot read the URDF: no such file");
    }
    if (!fs::is_regular_file(urdf_path_, error)) {
      fail("file", "cannot read the URDF: not a regular file");
    }
    const auto size = fs::file_size(urdf_path_, error);
    if (error || size > kMaxUrdfBytes) {
      fail("file", "cannot read the URDF: larger than 16 MiB");
    }
    std::ifstream in(urdf_path_, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    if (!in && !in.eof()) {
      fail("file", "cannot read the URDF: not readable");
    }
    xml_ = text.str();
    if (xml_.size() > kMaxUrdfBytes) {
      fail("file", "cannot read the URDF: larger than 16 MiB");
    }
    // TinyXML first: it knows where an XML error is, and where every link and joint starts.
    TiXmlDocument document;
    document.Parse(xml_.c_str());
    if (document.Error()) {
      fail("file", "line " + std::to_string(document.ErrorRow()) + " column " + std::to_string(document.ErrorCol()) +
                       ": malformed XML: " + document.ErrorDesc());
    }
    if (const TiXmlElement* robot = document.FirstChildElement("robot"); robot != nullptr) {
      for (const TiXmlElement* e = robot->FirstChildElement(); e != nullptr; e = e->NextSiblingElement()) {
        const char* name = e->Attribute("name");
        if (name != nullptr) lines_[std::string(e->Value()) + ":" + name] = e->Row();
      }
    }
    Messages messages;
    try {
      model_ = ::urdf::parseURDF(xml_);
    } catch (const std::exception& e) {  // urdfdom's ParseError where it does not catch it itself
      fail("file", std::string("not a valid URDF: ") + e.what());
    }
    if (!model_ || !messages.text().empty()) {
      fail("file", "not a valid URDF: " + (messages.text().empty() ? std::string("urdfdom gives no reason") : messages.text()));
    }
    if (!model_->getRoot()) {
      fail("file", "not a valid URDF: no root link");
    }
  }

  void index_joint_entries() {
    for (int i = 0; i < urdf_.joint_size(); ++i) {
      const proto::UrdfJoint& entry = urdf_.joint(i);
      if (entry.name().empty()) {
        file_.fail(urdf_, "joint", i, "a joint entry needs the name of a URDF joint");
      }
      if (!entries_.emplace(entry.name(), &entry).second) {
        file_.fail(entry, "name", -1, "joint '" + entry.name() + "' has two entries");
      }
      ::urdf::JointConstSharedPtr joint = model_->getJoint(entry.name());
      if (!joint) {
        std::string known;
        for (const auto& [name, j] : model_->joints_) {
          if (movable(*j) && known.size() < 512) known += (known.empty() ? "" : ", ") + shown(name);
        }
        file_.fail(entry, "name", -1,
                   urdf_path_.string() + ": has no joint '" + entry.name() + "' (its movable joints: " + known + ")");
      }
      if (!movable(*joint)) {
        file_.fail(entry, "name", -1,
                   urdf_path_.string() + ": " + where("joint", entry.name()) + " is " + joint_kind(*joint) +
                       (joint->type == ::urdf::Joint::FIXED ? ": it takes no servo" : ": not supported (revolute, continuous, prismatic or fixed)"));
      }
      if (entry.passive() && (entry.bus() != 0 || entry.id() != 0 || !entry.model().empty())) {
        file_.fail(entry, "passive", -1, "a passive joint has no servo: drop bus, id and model");
      }
    }
  }

  // Every link's frame in the robot frame at the design pose, parents first.
  void place_links() {
    ::urdf::LinkConstSharedPtr root = model_->getRoot();
    X_R_[root->name] = iso(urdf_.pose());
    std::vector<::urdf::LinkConstSharedPtr> stack{root};
    while (!stack.empty()) {
      ::urdf::LinkConstSharedPtr link = stack.back();
      stack.pop_back();
      order_.push_back(link);
      // Reverse so that children keep file order in the DFS.
      for (auto j = link->child_joints.rbegin(); j != link->child_joints.rend(); ++j) {
        const ::urdf::Joint& joint = **j;
        if (joint.type == ::urdf::Joint::FLOATING || joint.type == ::urdf::Joint::PLANAR || joint.type == ::urdf::Joint::UNKNOWN) {
          fail("file", where("joint", joint.name) + " is " + joint_kind(joint) +
                           ": not supported (revolute, continuous, prismatic or fixed)");
        }
        X_R_[joint.child_link_name] = X_R_[link->name] * iso(joint.parent_to_joint_origin_transform);
        stack.push_back(model_->getLink(joint.child_link_name));
      }
    }
    // Frames: links without mass and without collision, held by a fixed joint to a neighbour.
    for (const ::urdf::LinkConstSharedPtr& link : order_) {
      if (is_massive(*link)) continue;
      if (!link->collision_array.empty() || link->collision) {
        fail("file", where("link", link->name) + " has collision geometry but no <inertial> (mass): give it one");
      }
      if (link->parent_joint && link->parent_joint->type == ::urdf::Joint::FIXED) {
        continue;  // folded onto its parent's body below
      }
      // The root without mass: acceptable when exactly one fixed joint holds a body to it.
      if (!link->parent_joint && link->child_joints.size() == 1 && link->child_joints[0]->type == ::urdf::Joint::FIXED &&
          is_massive(*model_->getLink(link->child_joints[0]->child_link_name))) {
        continue;
      }
      fail("file", where("link", link->name) +
                       " has no <inertial> (mass) and is not held by a fixed joint: every moving part needs a mass");
    }
    for (const ::urdf::LinkConstSharedPtr& link : order_) {
      body_of_[link->name] = body_for(*link);
    }
  }

  static bool is_massive(const ::urdf::Link& link) { return link.inertial && link.inertial->mass > 0.0; }

  // The body a link belongs to (itself when massive, else the body its fixed joint leads to).
  std::string body_for(const ::urdf::Link& link) const {
    const ::urdf::Link* at = &link;
    for (int guard = 0; guard < 10000 && !is_massive(*at); ++guard) {
      if (at->parent_joint) {
        at = model_->getLink(at->parent_joint->parent_link_name).get();
      } else {
        at = model_->getLink(at->child_joints[0]->child_link_name).get();
      }
    }
    return at->name;
  }

  void make_bodies() {
    for (const ::urdf::LinkConstSharedPtr& link : order_) {
      if (!is_massive(*link)) continue;
      proto::Body& body = *figure_.add_body();
      file_.alias(body, urdf_);
      body.set_name(link->name);
      set(body.mutable_pose(), X_R_[link->name]);
      body.set_material(urdf_.material());
      const ::urdf::Inertial& in = *link->inertial;
      proto::Inertial& inertial = *body.mutable_inertial();
      inertial.set_mass_kg(in.mass);
      set(inertial.mutable_origin(), iso(in.origin));
      inertial.set_ixx_kg_m2(in.ixx);
      inertial.set_ixy_kg_m2(in.ixy);
      inertial.set_ixz_kg_m2(in.ixz);
      inertial.set_iyy_kg_m2(in.iyy);
      inertial.set_iyz_kg_m2(in.iyz);
      inertial.set_izz_kg_m2(in.izz);
      check_inertia(*link);
      std::vector<::urdf::CollisionSharedPtr> collisions = link->collision_array;
      if (collisions.empty() && link->collision) collisions.push_back(link->collision);
      for (size_t c = 0; c < collisions.size(); ++c) {
        add_shape(*link, c, *collisions[c], &body);
      }
      body.mutable_color()->set_r(160);
      body.mutable_color()->set_g(160);
      body.mutable_color()->set_b(160);
      for (const ::urdf::VisualSharedPtr& visual : link->visual_array) {
        if (visual && visual->material) {
          const ::urdf::Color& c = visual->material->color;
          auto byte = [](float v) { return static_cast<uint32_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); };
          body.mutable_color()->set_r(byte(c.r));
          body.mutable_color()->set_g(byte(c.g));
          body.mutable_color()->set_b(byte(c.b));
          break;
        }
      }
    }
  }

  void check_inertia(const ::urdf::Link& link) const {
    const ::urdf::Inertial& in = *link.inertial;
    Eigen::Matrix3d I;
    I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
    const Eigen::Vector3d m = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I).eigenvalues();
    std::ostringstream moments;
    moments << m.x() << ", " << m.y() << ", " << m.z();
    if (!I.allFinite() || !(m.minCoeff() > 0.0)) {
      fail("file", where("link", link.name) + ": <inertia> is not positive definite (principal moments " +
                       moments.str() + " kg m^2)");
    }
    if (m.z() > (m.x() + m.y()) * (1.0 + 1e-6)) {
      fail("file", where("link", link.name) + ": <inertia> violates the triangle inequality (principal moments " +
                       moments.str() + " kg m^2): no rigid body has it");
    }
  }

  void add_shape(const ::urdf::Link& link, size_t index, const ::urdf::Collision& collision, proto::Body* body) {
    const std::string element = where("link", link.name) + ": <collision> " + std::to_string(index + 1) +
                                (collision.name.empty() ? "" : " '" + shown(collision.name) + "'");
    if (!collision.geometry) {
      fail("file", element + ": no geometry");
    }
    proto::Shape& shape = *body->add_shape();
    set(shape.mutable_pose(), iso(collision.origin));
    auto positive = [&](double v, const std::string& what) {
      if (!(v > 0.0) || !std::isfinite(v)) {
        fail("file", element + ": " + what + " must be > 0 (got " + std::to_string(v) + ")");
      }
    };
    switch (collision.geometry->type) {
      case ::urdf::Geometry::BOX: {
        const auto& box = static_cast<const ::urdf::Box&>(*collision.geometry);
        positive(std::min({box.dim.x, box.dim.y, box.dim.z}), "<box size>");
        set(shape.mutable_box()->mutable_size_m(), Eigen::Vector3d(box.dim.x, box.dim.y, box.dim.z));
        break;
      }
      case ::urdf::Geometry::SPHERE: {
        const auto& sphere = static_cast<const ::urdf::Sphere&>(*collision.geometry);
        positive(sphere.radius, "<sphere radius>");
        shape.mutable_sphere()->set_radius_m(sphere.radius);
        break;
      }
      case ::urdf::Geometry::CYLINDER: {
        const auto& cylinder = static_cast<const ::urdf::Cylinder&>(*collision.geometry);
        positive(cylinder.radius, "<cylinder radius>");
        positive(cylinder.length, "<cylinder length>");
        shape.mutable_cylinder()->set_radius_m(cylinder.radius);
        shape.mutable_cylinder()->set_length_m(cylinder.length);
        break;
      }
      case ::urdf::Geometry::MESH: {
        const auto& mesh = static_cast<const ::urdf::Mesh&>(*collision.geometry);
        const Eigen::Vector3d scale(mesh.scale.x, mesh.scale.y, mesh.scale.z);
        positive(scale.minCoeff(), "<mesh scale>");
        const std::string what = element + ": <mesh filename=\"" + shown(mesh.filename) + "\">";
        const fs::path path = resolve(mesh.filename, what);
        std::vector<Eigen::Vector3d> points = mesh_points(path, what);
        for (Eigen::Vector3d& p : points) p = p.cwiseProduct(scale);
        std::shared_ptr<const physics::ConvexHull> hull;
        try {
          hull = physics::convex_hull(points);
        } catch (const std::invalid_argument& e) {
          fail("file", what + ": " + shown(path.string(), 256) + ": no convex hull: " + e.what());
        }
        proto::Convex& convex = *shape.mutable_convex();
        for (const Eigen::Vector3d& v : hull->vertices) set(convex.add_point_m(), v);
        break;
      }
      default:
        fail("file", element + ": unsupported geometry");
    }
  }

  // The file a mesh URI names: package://NAME/rest through package_path and ROS_PACKAGE_PATH,
  // file:///absolute, or a path relative to the URDF's directory.
  fs::path resolve(const std::string& uri, const std::string& what) const {
    constexpr std::string_view kPackage = "package://";
    constexpr std::string_view kFile = "file://";
    std::error_code error;
    if (uri.rfind(kPackage, 0) == 0) {
      const std::string rest = uri.substr(kPackage.size());
      const size_t slash = rest.find('/');
      if (slash == std::string::npos || slash == 0) {
        fail("file", what + ": a package URI is package://NAME/path");
      }
      const std::string package = rest.substr(0, slash);
      const std::string inside = rest.substr(slash + 1);
      std::vector<fs::path> roots;
      for (const std::string& dir : urdf_.package_path()) roots.push_back(robot_dir_ / dir);
      if (const char* env = std::getenv("ROS_PACKAGE_PATH"); env != nullptr) {
        std::stringstream list(env);
        for (std::string dir; std::getline(list, dir, ':');) {
          if (!dir.empty()) roots.emplace_back(dir);
        }
      }
      std::string searched;
      for (const fs::path& root : roots) {
        for (const fs::path& candidate :
             {root / package / inside, root.filename() == package ? root / inside : fs::path()}) {
          if (!candidate.empty() && fs::is_regular_file(candidate, error)) return candidate.lexically_normal();
        }
        if (searched.size() < 512) searched += (searched.empty() ? "" : ", ") + shown((root / package).string(), 128);
      }
      fail("file", what + ": package '" + shown(package) + "' has no file '" + shown(inside) + "' (searched " +
                       (searched.empty() ? std::string("nothing: set Urdf.package_path or ROS_PACKAGE_PATH") : searched) +
                       ")");
    }
    fs::path path = uri.rfind(kFile, 0) == 0 ? fs::path(uri.substr(kFile.size())) : fs::path(uri);
    if (path.is_relative()) path = urdf_path_.parent_path() / path;
    if (!fs::is_regular_file(path, error)) {
      fail("file", what + ": mesh file " + shown(path.lexically_normal().string(), 256) + " not found");
    }
    return path.lexically_normal();
  }

  // Every vertex of every mesh in the file, through the node transforms (DAE units included).
  std::vector<Eigen::Vector3d> mesh_points(const fs::path& path, const std::string& what) const {
    std::error_code error;
    if (fs::file_size(path, error) > kMaxMeshBytes || error) {
      fail("file", what + ": " + shown(path.string(), 256) + ": cannot read mesh: larger than 256 MiB");
    }
    Assimp::Importer importer;
    // URDF meshes are in the link frame as written: COLLADA's up axis is not applied, its <unit>
    // is (as DART loads URDF meshes: dartsim/dart dart/dynamics/MeshShape.cpp, commit b6bd9fe4).
    importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
    const aiScene* scene = importer.ReadFile(path.string(), 0);
    if (scene == nullptr || scene->mRootNode == nullptr) {
      fail("file", what + ": " + shown(path.string(), 256) + ": cannot read mesh: " + shown(importer.GetErrorString(), 256));
    }
    std::vector<Eigen::Vector3d> points;
    std::vector<std::pair<const aiNode*, aiMatrix4x4>> stack{{scene->mRootNode, scene->mRootNode->mTransformation}};
    while (!stack.empty()) {
      auto [node, transform] = stack.back();
      stack.pop_back();
      for (unsigned m = 0; m < node->mNumMeshes; ++m) {
        const aiMesh* mesh = scene->mMeshes[node->mMeshes[m]];
        for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
          const aiVector3D p = transform * mesh->mVertices[v];
          points.emplace_back(p.x, p.y, p.z);
        }
      }
      for (unsigned c = 0; c < node->mNumChildren; ++c) {
        stack.emplace_back(node->mChildren[c], transform * node->mChildren[c]->mTransformation);
      }
    }
    if (points.empty()) {
      fail("file", what + ": " + shown(path.string(), 256) + ": the mesh has no vertices");
    }
    // A triangle soup repeats each vertex; the hull needs each once.
    std::sort(points.begin(), points.end(), [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
      return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
    });
    points.erase(std::unique(points.begin(), points.end()), points.end());
    return points;
  }

  void make_links() {
    std::set<std::string> mapped;
    for (const ::urdf::LinkConstSharedPtr& link : order_) {
      for (const ::urdf::JointSharedPtr& j : link->child_joints) {
        const ::urdf::Joint& joint = *j;
        const std::string parent = body_of_.at(joint.parent_link_name);
        const std::string child = body_of_.at(joint.child_link_name);
        if (parent == child) continue;  // a frame folded onto its body
        proto::Link& out = *figure_.add_link();
        file_.alias(out, urdf_);
        out.set_name(joint.name);
        out.set_parent(parent);
        out.set_child(child);
        const Eigen::Isometry3d& X_RJ = X_R_.at(joint.child_link_name);  // the joint frame is the child's
        set(out.mutable_anchor_m(), X_RJ.translation());
        if (joint.type == ::urdf::Joint::FIXED) {
          out.set_type(proto::LINK_FIXED);
          continue;
        }
        const Eigen::Vector3d axis_J(joint.axis.x, joint.axis.y, joint.axis.z);
        if (!(axis_J.norm() > 1e-9)) {
          fail("file", where("joint", joint.name) + ": <axis> is zero");
        }
        set(out.mutable_axis(), X_RJ.linear() * axis_J.normalized());
        const bool prismatic = joint.type == ::urdf::Joint::PRISMATIC;
        out.set_type(prismatic ? proto::LINK_PRISMATIC : proto::LINK_REVOLUTE);
        if (joint.type != ::urdf::Joint::CONTINUOUS && joint.limits) {
          double lower = joint.limits->lower, upper = joint.limits->upper;
          if (!(lower <= upper)) {
            fail("file", where("joint", joint.name) + ": <limit> lower " + std::to_string(lower) + " above upper " +
                             std::to_string(upper));
          }
          if (prismatic) {
            out.set_lower_m(lower);
            out.set_upper_m(upper);
          } else if (lower > -std::numbers::pi || upper < std::numbers::pi) {
            // Beyond a half turn either way a revolute limit cannot be told from the other side.
            out.set_lower_deg(std::max(lower, -std::numbers::pi) * kRadToDeg);
            out.set_upper_deg(std::min(upper, std::numbers::pi) * kRadToDeg);
          }
        }
        auto entry = entries_.find(joint.name);
        if (entry == entries_.end()) {
          fail("joint", where("joint", joint.name) + " (" + joint_kind(joint) +
                            ") has no servo: add joint { name: \"" + joint.name +
                            "\" bus: B id: N } or joint { name: \"" + joint.name + "\" passive: true }",
               urdf_.joint_size() > 0 ? urdf_.joint_size() - 1 : -1);
        }
        const proto::UrdfJoint& e = *entry->second;
        mapped.insert(joint.name);
        file_.alias(out, e);
        if (e.initial_deg() != 0.0) out.set_initial_deg(e.initial_deg());
        if (e.initial_m() != 0.0) out.set_initial_m(e.initial_m());
        if (!e.passive()) {
          proto::Motor& motor = *out.mutable_motor();
          file_.alias(motor, e);
          motor.set_bus(e.bus());
          motor.set_id(e.id());
          motor.set_model(e.model());
          motor.set_reversed(e.reversed());
          motor.set_offset_deg(e.offset_deg());
          if (e.has_back_emf_v_s_rad()) motor.set_back_emf_v_s_rad(e.back_emf_v_s_rad());
          if (e.has_resistance_ohm()) motor.set_resistance_ohm(e.resistance_ohm());
          if (e.has_torque_constant_nm_a()) motor.set_torque_constant_nm_a(e.torque_constant_nm_a());
        }
      }
    }
    for (const auto& [name, entry] : entries_) {
      if (mapped.count(name) == 0U) {  // a movable joint that joins a frame: cannot happen after place_links
        file_.fail(*entry, "name", -1, urdf_path_.string() + ": joint '" + name + "' joins no two bodies");
      }
    }
  }

  // Sensors that name a frame (a link folded onto a body) move onto that body.
  void move_sensors() {
    auto rebase = [&](google::protobuf::Message& sensor, std::string* body, auto&& move) {
      auto found = body_of_.find(*body);
      if (found == body_of_.end()) {
        file_.fail(sensor, "body", -1,
                   "unknown body '" + *body + "': the URDF " + urdf_path_.string() + " has no such link");
      }
      if (found->second == *body) return;
      const Eigen::Isometry3d X_BF = X_R_.at(found->second).inverse() * X_R_.at(*body);
      *body = found->second;
      move(X_BF);
    };
    for (proto::Imu& s : *figure_.mutable_imu()) {
      rebase(s, s.mutable_body(), [&](const Eigen::Isometry3d& X) { set(s.mutable_mount(), X * iso(s.mount())); });
    }
    for (proto::CameraMount& s : *figure_.mutable_camera()) {
      rebase(s, s.mutable_body(), [&](const Eigen::Isometry3d& X) { set(s.mutable_mount(), X * iso(s.mount())); });
    }
    for (proto::FootSensor& s : *figure_.mutable_foot()) {
      rebase(s, s.mutable_body(), [&](const Eigen::Isometry3d& X) {
        for (proto::Vector3& c : *s.mutable_cell_m()) set(&c, X * Eigen::Vector3d(c.x(), c.y(), c.z()));
      });
    }
  }

  proto::RobotFile& file_;
  proto::Figure& figure_;
  const proto::Urdf& urdf_;
  fs::path robot_dir_;
  fs::path urdf_path_;
  std::string xml_;
  std::map<std::string, int> lines_;  // "link:NAME" / "joint:NAME" -> line in the URDF
  ::urdf::ModelInterfaceSharedPtr model_;
  std::map<std::string, const proto::UrdfJoint*> entries_;
  std::map<std::string, Eigen::Isometry3d> X_R_;  // link frames in R at the design pose
  std::vector<::urdf::LinkConstSharedPtr> order_; // parents first
  std::map<std::string, std::string> body_of_;    // link -> the body it is part of
};

}  // namespace

void expand(proto::RobotFile& file) {
  if (!file.description().has_figure() || !file.description().figure().has_urdf()) return;
  Importer(file).run();
}

proto::RobotFile load_robot_file(const std::string& path) {
  proto::RobotFile file = proto::RobotFile::load(path);
  expand(file);
  return file;
}

proto::RobotFile parse_robot_file(const std::string& text, const std::string& path) {
  proto::RobotFile file = proto::RobotFile::parse(text, path);
  expand(file);
  return file;
}

}  // namespace doppel::urdf
