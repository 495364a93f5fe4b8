// ODE backend: rigid bodies and ODE joints stepped with QuickStep (iterative, O(n) per sweep).
// The DC-motor law tau = b (w0 - w), |tau| <= cap is the joint's own motor row: dParamVel = w0,
// dParamFMax = cap and dParamCFM = 1/b, because with constraint force mixing ODE solves
// J v_new = w0 - CFM * tau, i.e. exactly that law with the new velocity (implicit, so the stiff
// back-EMF damping of a geared motor stays stable at 1 ms).

#include <ode/ode.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "physics/backend.h"
#include "physics/block_pool.h"
#include "physics/engines.h"

namespace doppel::physics {
namespace {

constexpr int kMaxContactsPerPair = 8;
constexpr size_t kMaxReportedContacts = 512;  // contacts on bodies that report them, per step
constexpr double kContactErp = 0.2;
constexpr double kContactCfm = 1e-5;

std::once_flag g_ode_once;

// ODE frees the arena of the step's contact joints after every step and allocates it again in
// the next one: its allocation hooks go to the block pool, so the steady state does not call malloc.
void* ode_alloc(dsizeint size) { return BlockPool::allocate(size); }

void ode_free(void* block, dsizeint) { BlockPool::release(block); }

void* ode_realloc(void* block, dsizeint old_size, dsizeint new_size) {
  void* fresh = BlockPool::allocate(new_size);
  if (fresh != nullptr && block != nullptr) std::memcpy(fresh, block, std::min(old_size, new_size));
  BlockPool::release(block);
  return fresh;
}

thread_local bool t_ode_thread_ready = false;

void ensure_ode_thread() noexcept {
  if (!t_ode_thread_ready) {
    dAllocateODEDataForThread(dAllocateMaskAll);
    t_ode_thread_ready = true;
  }
}

struct GeomInfo {
  int body = -1;  // backend body index, -1 = static
  MaterialSpec material;
  bool report = false;
};

struct Reported {
  int body = -1;           // the reporting body
  bool is_first = true;    // it is the contact joint's first body
  dJointFeedback* feedback = nullptr;
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
};

class OdeBackend final : public Backend {
 public:
  OdeBackend() {
    std::call_once(g_ode_once, [] {
      dSetAllocHandler(&ode_alloc);
      dSetReallocHandler(&ode_realloc);
      dSetFreeHandler(&ode_free);
      dInitODE2(0);
    });
    ensure_ode_thread();
  }

  ~OdeBackend() override {
    if (contacts_ != nullptr) dJointGroupDestroy(contacts_);
    if (space_ != nullptr) dSpaceDestroy(space_);
    if (world_ != nullptr) dWorldDestroy(world_);
  }

  void init(const BackendOptions& options) override {
    world_ = dWorldCreate();
    space_ = dSimpleSpaceCreate(nullptr);  // the hash space allocates a std::vector in every collide
    contacts_ = dJointGroupCreate(0);
    dWorldSetGravity(world_, 0.0, 0.0, -options.gravity_m_s2);
    dWorldSetERP(world_, 0.2);
    dWorldSetCFM(world_, 1e-9);
    dWorldSetQuickStepNumIterations(world_, options.solver_iterations);
    dWorldSetContactSurfaceLayer(world_, 0.0005);
    dWorldSetContactMaxCorrectingVel(world_, 1.0);
    dWorldSetAutoDisableFlag(world_, 0);
    dWorldSetQuickStepW(world_, 1.0);
    feedback_.resize(kMaxReportedContacts);
    reported_.resize(kMaxReportedContacts);
    step_s_ = options.step_s;
  }

  int add_body(const BodyDesc& desc) override {
    ensure_ode_thread();  // a robot added at run time: on whichever thread adds it
    dBodyID body = dBodyCreate(world_);
    dMass mass;
    dMassSetParameters(&mass, desc.mass_kg, 0.0, 0.0, 0.0, desc.inertia_kg_m2.x(), desc.inertia_kg_m2.y(),
                       desc.inertia_kg_m2.z(), 0.0, 0.0, 0.0);
    dBodySetMass(body, &mass);
    dBodySetGyroscopicMode(body, desc.gyroscopic ? 1 : 0);
    const int index = static_cast<int>(bodies_.size());
    auto info = std::make_unique<GeomInfo>(GeomInfo{index, desc.material, desc.report_contacts});
    for (size_t s = 0; s < desc.shape_count; ++s) {
      Eigen::Vector3d centre;
      dGeomID geom = make_geom(desc.shapes[s], &centre);
      if (geom == nullptr) continue;
      dGeomSetBody(geom, body);
      const Eigen::Vector3d p = desc.shapes[s].X_BS * centre;
      dGeomSetOffsetPosition(geom, p.x(), p.y(), p.z());
      dMatrix3 R;
      to_ode(desc.shapes[s].X_BS.linear(), R);
      dGeomSetOffsetRotation(geom, R);
      set_group(geom, desc.group, desc.self_collide);
      dGeomSetData(geom, info.get());
    }
    infos_.push_back(std::move(info));
    bodies_.push_back(body);
    pins_.push_back(nullptr);
    exempt_.emplace_back();
    set_body_state(index, desc.X_WB, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    return index;
  }

  void add_static(const ShapeSpec& shape, const MaterialSpec& material) override {
    Eigen::Vector3d centre;
    dGeomID geom = make_geom(shape, &centre);
    if (geom == nullptr) return;
    const Eigen::Vector3d p = shape.X_BS * centre;
    dGeomSetPosition(geom, p.x(), p.y(), p.z());
    dMatrix3 R;
    to_ode(shape.X_BS.linear(), R);
    dGeomSetRotation(geom, R);
    set_group(geom, kGroupStatic, false);
    infos_.push_back(std::make_unique<GeomInfo>(GeomInfo{-1, material, false}));
    dGeomSetData(geom, infos_.back().get());
  }

  void add_ground(const MaterialSpec& material) override {
    dGeomID plane = dCreatePlane(space_, 0.0, 0.0, 1.0, 0.0);
    set_group(plane, kGroupStatic, false);
    infos_.push_back(std::make_unique<GeomInfo>(GeomInfo{-1, material, false}));
    dGeomSetData(plane, infos_.back().get());
  }

  int add_joint(const JointDesc& desc) override {
    dBodyID child = bodies_.at(static_cast<size_t>(desc.child));
    dBodyID parent = desc.parent >= 0 ? bodies_.at(static_cast<size_t>(desc.parent)) : nullptr;
    dJointID joint = nullptr;
    dJointID friction = nullptr;
    const Eigen::Vector3d& a = desc.anchor_W;
    const Eigen::Vector3d& u = desc.axis_W;
    switch (desc.type) {
      case JointType::kRevolute:
        joint = dJointCreateHinge(world_, nullptr);
        dJointAttach(joint, child, parent);
        dJointSetHingeAnchor(joint, a.x(), a.y(), a.z());
        dJointSetHingeAxis(joint, u.x(), u.y(), u.z());
        if (desc.limited) {
          dJointSetHingeParam(joint, dParamLoStop, desc.lower);
          dJointSetHingeParam(joint, dParamHiStop, desc.upper);
        }
        // Gear friction: a one-axis angular motor at zero speed, bounded by the friction torque.
        friction = dJointCreateAMotor(world_, nullptr);
        dJointAttach(friction, child, parent);
        dJointSetAMotorMode(friction, dAMotorUser);
        dJointSetAMotorNumAxes(friction, 1);
        dJointSetAMotorAxis(friction, 0, 1, u.x(), u.y(), u.z());
        dJointSetAMotorParam(friction, dParamVel, 0.0);
        dJointSetAMotorParam(friction, dParamFMax, 0.0);
        break;
      case JointType::kPrismatic:
        joint = dJointCreateSlider(world_, nullptr);
        dJointAttach(joint, child, parent);
        dJointSetSliderAxis(joint, u.x(), u.y(), u.z());
        if (desc.limited) {
          dJointSetSliderParam(joint, dParamLoStop, desc.lower);
          dJointSetSliderParam(joint, dParamHiStop, desc.upper);
        }
        break;
      case JointType::kSpherical:
        joint = dJointCreateBall(world_, nullptr);
        dJointAttach(joint, child, parent);
        dJointSetBallAnchor(joint, a.x(), a.y(), a.z());
        break;
      case JointType::kFixed:
        joint = dJointCreateFixed(world_, nullptr);
        dJointAttach(joint, child, parent);
        dJointSetFixed(joint);
        break;
    }
    joints_.push_back(Joint{joint, desc.type, child, parent, friction});
    return static_cast<int>(joints_.size()) - 1;
  }

  void exclude_collision(int a, int b) override {
    exempt_.at(static_cast<size_t>(a)).push_back(b);
    exempt_.at(static_cast<size_t>(b)).push_back(a);
  }

  void finalize() override {}

  void remove_joint(int index) override {
    Joint& j = joints_.at(static_cast<size_t>(index));
    if (j.friction != nullptr) dJointDestroy(j.friction);
    if (j.id != nullptr) dJointDestroy(j.id);
    j = Joint{nullptr, j.type, nullptr, nullptr, nullptr};
  }

  void remove_body(int index) override {
    dBodyID& body = bodies_.at(static_cast<size_t>(index));
    if (body == nullptr) return;
    // Geoms leave the space as they are destroyed: nothing collides with the body any more.
    for (dGeomID geom = dBodyGetFirstGeom(body); geom != nullptr; geom = dBodyGetFirstGeom(body)) {
      dGeomDestroy(geom);
    }
    dJointID& pin = pins_[static_cast<size_t>(index)];
    if (pin != nullptr) dJointDestroy(pin);
    pin = nullptr;
    dBodyDestroy(body);
    body = nullptr;
    exempt_[static_cast<size_t>(index)].clear();
  }

  void set_body_state(int index, const Eigen::Isometry3d& X_WB, const Eigen::Vector3d& v,
                      const Eigen::Vector3d& w) noexcept override {
    dBodyID body = bodies_[static_cast<size_t>(index)];
    const Eigen::Vector3d p = X_WB.translation();
    dBodySetPosition(body, p.x(), p.y(), p.z());
    const Eigen::Quaterniond q(X_WB.linear());
    const dQuaternion oq = {q.w(), q.x(), q.y(), q.z()};
    dBodySetQuaternion(body, oq);
    dBodySetLinearVel(body, v.x(), v.y(), v.z());
    dBodySetAngularVel(body, w.x(), w.y(), w.z());
  }

  void set_pinned(int index, bool pinned) noexcept override {
    dJointID& pin = pins_[static_cast<size_t>(index)];
    if (!pinned) {
      if (pin != nullptr) dJointDisable(pin);
      return;
    }
    if (pin == nullptr) {
      pin = dJointCreateFixed(world_, nullptr);
      dJointAttach(pin, bodies_[static_cast<size_t>(index)], nullptr);
    }
    dJointEnable(pin);
    dJointSetFixed(pin);
  }

  void set_drive(int index, const DriveLaw& law) noexcept override {
    const Joint& j = joints_[static_cast<size_t>(index)];
    const double cfm = std::isinf(law.damping) || law.damping <= 0.0 ? 0.0 : 1.0 / law.damping;
    if (j.type == JointType::kRevolute) {
      dJointSetHingeParam(j.id, dParamFMax, law.max_torque);
      dJointSetHingeParam(j.id, dParamVel, law.target_velocity);
      dJointSetHingeParam(j.id, dParamCFM, cfm);
      dJointSetAMotorParam(j.friction, dParamFMax, law.friction_torque);
    } else if (j.type == JointType::kPrismatic) {
      dJointSetSliderParam(j.id, dParamFMax, law.max_torque);
      dJointSetSliderParam(j.id, dParamVel, law.target_velocity);
      dJointSetSliderParam(j.id, dParamCFM, cfm);
    }
  }

  void add_force(int index, const Eigen::Vector3d& f_W) noexcept override {
    dBodyID body = bodies_[static_cast<size_t>(index)];
    dBodyEnable(body);
    dBodyAddForce(body, f_W.x(), f_W.y(), f_W.z());  // ODE zeroes the accumulator after each step
  }

  void step(double dt_s) noexcept override {
    ensure_ode_thread();
    BlockPool::stock(8);
    reported_count_ = 0;
    feedback_count_ = 0;
    dRandSetSeed(seed_);  // QuickStep reorders constraints with ODE's global generator: keep it per world
    dSpaceCollide(space_, this, &OdeBackend::near_callback);
    dWorldQuickStep(world_, dt_s);
    seed_ = dRandGetSeed();
    for (size_t i = 0; i < reported_count_; ++i) {
      Reported& r = reported_[i];
      const dReal* f = r.is_first ? r.feedback->f1 : r.feedback->f2;
      results_[i] = ContactForce{r.p_W, Eigen::Vector3d(f[0], f[1], f[2])};
    }
    dJointGroupEmpty(contacts_);
  }

  JointReading joint(int index) const noexcept override {
    const Joint& j = joints_[static_cast<size_t>(index)];
    switch (j.type) {
      case JointType::kRevolute:
        return JointReading{dJointGetHingeAngle(j.id), dJointGetHingeAngleRate(j.id)};
      case JointType::kPrismatic:
        return JointReading{dJointGetSliderPosition(j.id), dJointGetSliderPositionRate(j.id)};
      default:
        return JointReading{};
    }
  }

  BodyReading body(int index) const noexcept override {
    dBodyID body = bodies_[static_cast<size_t>(index)];
    BodyReading r;
    const dReal* p = dBodyGetPosition(body);
    const dReal* q = dBodyGetQuaternion(body);
    const dReal* v = dBodyGetLinearVel(body);
    const dReal* w = dBodyGetAngularVel(body);
    r.X_WB.linear() = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
    r.X_WB.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
    r.v_WB_W = Eigen::Vector3d(v[0], v[1], v[2]);
    r.w_WB_W = Eigen::Vector3d(w[0], w[1], w[2]);
    return r;
  }

  size_t contacts(int index, ContactForce* out, size_t capacity) const noexcept override {
    size_t n = 0;
    for (size_t i = 0; i < reported_count_ && n < capacity; ++i) {
      if (reported_[i].body == index) {
        out[n++] = results_[i];
      }
    }
    return n;
  }

  std::string_view name() const noexcept override { return "ode"; }

 private:
  struct Joint {
    dJointID id = nullptr;
    JointType type = JointType::kRevolute;
    dBodyID child = nullptr;
    dBodyID parent = nullptr;
    dJointID friction = nullptr;  // revolute joints: the gear friction's angular motor
  };

  static void to_ode(const Eigen::Matrix3d& R, dMatrix3 out) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        out[r * 4 + c] = R(r, c);
      }
      out[r * 4 + 3] = 0.0;
    }
  }

  // The geom of a shape; *centre is where in the shape frame the geom's origin must go.
  dGeomID make_geom(const ShapeSpec& s, Eigen::Vector3d* centre) {
    *centre = Eigen::Vector3d::Zero();
    switch (s.type) {
      case ShapeType::kBox: return dCreateBox(space_, s.size_m.x(), s.size_m.y(), s.size_m.z());
      case ShapeType::kSphere: return dCreateSphere(space_, s.size_m.x());
      case ShapeType::kCylinder: return dCreateCylinder(space_, s.size_m.x(), s.size_m.y());
      case ShapeType::kCapsule: return dCreateCapsule(space_, s.size_m.x(), s.size_m.y());
      case ShapeType::kConvex: {
        // ODE's convex collider wants the geom's origin inside the hull: the arrays are given
        // about the hull's centroid, and the geom is moved there (*centre). ODE keeps pointers
        // into them: they live with the backend.
        const ConvexHull& h = *s.hull;
        *centre = h.centroid;
        auto& data = hulls_.emplace_back(std::make_unique<OdeHull>());
        for (const Eigen::Vector4d& plane : h.planes) {
          data->planes.insert(data->planes.end(), {plane.x(), plane.y(), plane.z(), plane.w() - plane.head<3>().dot(h.centroid)});
        }
        for (const Eigen::Vector3d& v : h.vertices) {
          const Eigen::Vector3d p = v - h.centroid;
          data->points.insert(data->points.end(), {p.x(), p.y(), p.z()});
        }
        data->polygons = h.polygons;
        return dCreateConvex(space_, data->planes.data(), static_cast<unsigned>(h.face_count), data->points.data(),
                             static_cast<unsigned>(h.vertices.size()), data->polygons.data());
      }
      case ShapeType::kRing: return nullptr;
    }
    return nullptr;
  }

  // Group g collides with every other group; the ball group and self-colliding robots also with
  // themselves (then collide() skips the excluded pairs).
  static void set_group(dGeomID geom, uint32_t group, bool self_collide) {
    const unsigned long bit = 1UL << group;
    dGeomSetCategoryBits(geom, bit);
    dGeomSetCollideBits(geom, group == kGroupBall || self_collide ? ~0UL : ~bit);
  }

  static void near_callback(void* data, dGeomID a, dGeomID b) { static_cast<OdeBackend*>(data)->collide(a, b); }

  void collide(dGeomID a, dGeomID b) noexcept {
    dBodyID ba = dGeomGetBody(a);
    dBodyID bb = dGeomGetBody(b);
    if (ba == bb) return;  // two statics, or two shapes of one body
    const auto* ia = static_cast<const GeomInfo*>(dGeomGetData(a));
    const auto* ib = static_cast<const GeomInfo*>(dGeomGetData(b));
    if (ia->body >= 0 && ib->body >= 0) {
      const std::vector<int>& partners = exempt_[static_cast<size_t>(ia->body)];
      if (std::find(partners.begin(), partners.end(), ib->body) != partners.end()) return;
    }
    const int n = dCollide(a, b, kMaxContactsPerPair, &contact_scratch_[0].geom, sizeof(dContact));
    if (n <= 0) return;
    const double mu = ia->material.friction * ib->material.friction;
    const double bounce = ia->material.restitution * ib->material.restitution;
    for (int i = 0; i < n; ++i) {
      dContact& c = contact_scratch_[static_cast<size_t>(i)];
      c.surface.mode = dContactApprox1 | dContactSoftERP | dContactSoftCFM;
      c.surface.mu = mu;
      c.surface.soft_erp = kContactErp;
      c.surface.soft_cfm = kContactCfm;
      if (bounce > 0.0) {
        c.surface.mode |= dContactBounce;
        c.surface.bounce = bounce;
        c.surface.bounce_vel = 0.05;
      }
      dJointID joint = dJointCreateContact(world_, contacts_, &c);
      dJointAttach(joint, ba, bb);
      if ((!ia->report && !ib->report) || feedback_count_ >= kMaxReportedContacts) {
        continue;
      }
      dJointFeedback* fb = &feedback_[feedback_count_++];
      dJointSetFeedback(joint, fb);
      for (const GeomInfo* info : {ia, ib}) {
        if (info->report && reported_count_ < kMaxReportedContacts) {
          reported_[reported_count_++] =
              Reported{info->body, info == ia, fb, Eigen::Vector3d(c.geom.pos[0], c.geom.pos[1], c.geom.pos[2])};
        }
      }
    }
  }

  dWorldID world_ = nullptr;
  dSpaceID space_ = nullptr;
  dJointGroupID contacts_ = nullptr;
  double step_s_ = 0.001;
  unsigned long seed_ = 0;
  std::vector<dBodyID> bodies_;
  struct OdeHull {
    std::vector<dReal> planes;  // a, b, c, d per face (a x + b y + c z = d), about the centroid
    std::vector<dReal> points;  // x, y, z per vertex, about the centroid
    std::vector<unsigned> polygons;
  };
  std::vector<std::unique_ptr<OdeHull>> hulls_;  // arrays that dCreateConvex geoms point into
  std::vector<dJointID> pins_;
  std::vector<Joint> joints_;
  std::vector<std::unique_ptr<GeomInfo>> infos_;
  std::vector<std::vector<int>> exempt_;  // per body: bodies it never collides with
  std::vector<dJointFeedback> feedback_;
  std::vector<Reported> reported_;
  std::array<ContactForce, kMaxReportedContacts> results_{};
  size_t reported_count_ = 0;
  size_t feedback_count_ = 0;
  std::array<dContact, kMaxContactsPerPair> contact_scratch_{};
};

}  // namespace

std::unique_ptr<Backend> make_ode_backend() { return std::make_unique<OdeBackend>(); }

}  // namespace doppel::physics
