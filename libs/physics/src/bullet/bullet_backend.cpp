// Bullet backend (double precision): maximal-coordinate rigid bodies with btHingeConstraint and
// friends, solved by the sequential-impulse solver. Chosen over btMultiBody because it is several
// times faster per step on this machine (see dependencies.md) and matches ODE's formulation, so
// both engines answer the same question. The DC-motor law tau = b (w0 - w), |tau| <= cap is one
// extra constraint row per driven joint (DriveRow) whose constraint force mixing makes the solver
// return exactly that law at the new velocity (implicit, stable at 1 ms).

#include <BulletCollision/CollisionShapes/btConvexHullShape.h>
#include <BulletCollision/CollisionShapes/btEmptyShape.h>
#include <LinearMath/btConvexHullComputer.h>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "physics/backend.h"
#include "physics/block_pool.h"
#include "physics/engines.h"

namespace doppel::physics {
namespace {

constexpr size_t kMaxReportedContacts = 512;
constexpr btScalar kMargin = 0.001;
constexpr btScalar kContactBreakingThreshold_m = 0.005;
constexpr btScalar kBroadphaseHalfSize_m = 20.0;  // x and y: RoboCup fields with borders are at most 16 x 11 m
constexpr unsigned short kMaxBroadphaseObjects = 4096;

// Bullet's allocations go to the block pool (see block_pool.h), installed before Bullet allocates
// anything, so that the arrays Bullet grows during a step do not reach malloc.
std::once_flag g_bullet_once;
void* bullet_alloc(size_t size) { return BlockPool::allocate(size); }
void bullet_free(void* block) { BlockPool::release(block); }

btVector3 bt(const Eigen::Vector3d& v) { return btVector3(v.x(), v.y(), v.z()); }
Eigen::Vector3d eig(const btVector3& v) { return Eigen::Vector3d(v.x(), v.y(), v.z()); }

btTransform bt(const Eigen::Isometry3d& X) {
  const Eigen::Matrix3d& R = X.linear();
  btMatrix3x3 basis(R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2));
  return btTransform(basis, bt(Eigen::Vector3d(X.translation())));
}

Eigen::Isometry3d eig(const btTransform& T) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  const btMatrix3x3& B = T.getBasis();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      X.linear()(r, c) = B[r][c];
    }
  }
  X.translation() = eig(T.getOrigin());
  return X;
}

// A frame whose z axis is `axis` (unit) at `origin`.
Eigen::Isometry3d axis_frame(const Eigen::Vector3d& origin, const Eigen::Vector3d& axis) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d helper = std::abs(axis.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d x = (helper - helper.dot(axis) * axis).normalized();
  X.linear().col(0) = x;
  X.linear().col(1) = axis.cross(x);
  X.linear().col(2) = axis;
  X.translation() = origin;
  return X;
}

// The drive law on a hinge axis. Bullet's solver iterates a joint row as
// impulse_{k+1} = c - cfm * impulse_k, which converges only for cfm < 1; at convergence
// impulse * cfm = (target - w_new) / k with k = a' (IA^-1 + IB^-1) a. So a law stiff against the two
// bodies' inertia (k h b >= 1) is this row with cfm = 1 / (k h b) < 1 (implicit, exact at
// convergence), and a soft one (k h b < 1) is applied as an explicit torque, which is stable there
// (|1 - k h b| < 1). A rigid lock (b = infinity) is the row with cfm 0. Gear friction is a second
// row on the axis: zero relative speed, bounded by the friction torque.
class DriveRow final : public btTypedConstraint {
 public:
  DriveRow(btRigidBody& child, btRigidBody& parent, const btVector3& axis_in_child)
      : btTypedConstraint(GEAR_CONSTRAINT_TYPE, child, parent), axis_in_child_(axis_in_child) {}

  void set_law(const DriveLaw& law) { law_ = law; }

  btVector3 axis() const { return m_rbA.getWorldTransform().getBasis() * axis_in_child_; }

  btScalar inverse_inertia(const btVector3& a) const {
    return a.dot(m_rbA.getInvInertiaTensorWorld() * a) + a.dot(m_rbB.getInvInertiaTensorWorld() * a);
  }

  // Decides the mode for the coming step; applies the explicit torque when soft. rt-safe.
  void prepare(btScalar h) {
    row_ = false;
    if (law_.max_torque <= 0.0) return;
    if (std::isinf(law_.damping) || law_.damping <= 0.0) {
      row_ = true;
      cfm_ = 0.0;
      return;
    }
    const btVector3 a = axis();
    const btScalar khb = inverse_inertia(a) * h * law_.damping;
    if (khb >= 1.0) {
      row_ = true;
      cfm_ = 1.0 / khb;
      return;
    }
    const btScalar w = a.dot(m_rbA.getAngularVelocity() - m_rbB.getAngularVelocity());
    const btScalar torque = std::clamp(law_.damping * (law_.target_velocity - w), -law_.max_torque, law_.max_torque);
    m_rbA.applyTorque(a * torque);
    if (m_rbB.getInvMass() > 0.0) m_rbB.applyTorque(-a * torque);
  }

  void getInfo1(btConstraintInfo1* info) override {
    info->m_numConstraintRows = (row_ ? 1 : 0) + (law_.friction_torque > 0.0 ? 1 : 0);
    info->nub = 0;
  }

  void getInfo2(btConstraintInfo2* info) override {
    const btVector3 a = axis();
    const btScalar h = 1.0 / info->fps;
    int row = 0;
    if (row_) {
      set_row(info, row++, a, law_.target_velocity, law_.max_torque * h, cfm_);
    }
    if (law_.friction_torque > 0.0) {
      set_row(info, row, a, 0.0, law_.friction_torque * h, 0.0);
    }
  }

  static void set_row(btConstraintInfo2* info, int row, const btVector3& a, btScalar velocity, btScalar max_impulse,
                      btScalar cfm) {
    const int i = row * info->rowskip;
    info->m_J1angularAxis[i + 0] = a.x();
    info->m_J1angularAxis[i + 1] = a.y();
    info->m_J1angularAxis[i + 2] = a.z();
    info->m_J2angularAxis[i + 0] = -a.x();
    info->m_J2angularAxis[i + 1] = -a.y();
    info->m_J2angularAxis[i + 2] = -a.z();
    info->m_constraintError[i] = velocity;
    info->m_lowerLimit[i] = -max_impulse;
    info->m_upperLimit[i] = max_impulse;
    info->cfm[i] = cfm;
  }

  void setParam(int, btScalar, int) override {}
  btScalar getParam(int, int) const override { return 0.0; }

 private:
  btVector3 axis_in_child_;
  DriveLaw law_;
  bool row_ = false;
  btScalar cfm_ = 0.0;
};

struct Joint {
  JointType type = JointType::kRevolute;
  int child = -1;
  int parent = -1;                 // -1 = world
  Eigen::Vector3d axis_P;          // axis in the parent's frame (world if no parent)
  btVector3 ref_C;                 // a unit vector normal to the axis, fixed in the child
  btVector3 ref_P0;                // the same vector at creation, in the parent's frame
  btVector3 ref_P0_normal;         // axis x ref_P0, parent's frame
  Eigen::Vector3d anchor_C;        // anchor in the child's frame
  Eigen::Vector3d anchor_P;        // anchor in the parent's frame
  std::unique_ptr<btTypedConstraint> constraint;
  std::unique_ptr<DriveRow> drive;
};

struct Reported {
  int body = -1;
  ContactForce force;
};

// The dynamics world with two passes skipped that do nothing for Doppel. Without continuous
// collision detection (no body sets a CCD threshold) the predictive-contact pass only integrates
// every body once more; and with sleeping disabled, simulation islands only sort the constraints
// every step: one solver call over all bodies, contacts and constraints gives the same answer.
class BulletWorld final : public btDiscreteDynamicsWorld {
 public:
  using btDiscreteDynamicsWorld::btDiscreteDynamicsWorld;

  void add_solver_body(btRigidBody* body) { solver_bodies_.push_back(body); }
  void remove_solver_body(btRigidBody* body) { solver_bodies_.remove(body); }

 protected:
  void createPredictiveContacts(btScalar) override {}

  void calculateSimulationIslands() override {}

  void solveConstraints(btContactSolverInfo& info) override {
    const int bodies = solver_bodies_.size();
    const int manifolds = m_dispatcher1->getNumManifolds();
    const int constraints = m_constraints.size();
    m_constraintSolver->prepareSolve(bodies, manifolds);
    m_constraintSolver->solveGroup(bodies > 0 ? &solver_bodies_[0] : nullptr, bodies,
                                   manifolds > 0 ? m_dispatcher1->getInternalManifoldPointer() : nullptr, manifolds,
                                   constraints > 0 ? &m_constraints[0] : nullptr, constraints, info, m_debugDrawer,
                                   m_dispatcher1);
    m_constraintSolver->allSolved(info, m_debugDrawer);
  }

 private:
  btAlignedObjectArray<btCollisionObject*> solver_bodies_;
};

// Broadphase pairs: the collision groups' masks, then the pairs excluded by exclude_collision(), so
// that exempt pairs of one robot never reach the pair cache.
class PairFilter final : public btOverlapFilterCallback {
 public:
  explicit PairFilter(const std::vector<std::vector<int>>& exempt) : exempt_(exempt) {}

  bool needBroadphaseCollision(btBroadphaseProxy* a, btBroadphaseProxy* b) const override {
    if ((a->m_collisionFilterGroup & b->m_collisionFilterMask) == 0 ||
        (b->m_collisionFilterGroup & a->m_collisionFilterMask) == 0) {
      return false;
    }
    const int ia = static_cast<const btCollisionObject*>(a->m_clientObject)->getUserIndex();
    const int ib = static_cast<const btCollisionObject*>(b->m_clientObject)->getUserIndex();
    if (ia < 0 || ib < 0) return true;
    const std::vector<int>& partners = exempt_[static_cast<size_t>(ia)];
    return std::find(partners.begin(), partners.end(), ib) == partners.end();
  }

 private:
  const std::vector<std::vector<int>>& exempt_;
};

class BulletBackend final : public Backend {
 public:
  BulletBackend() {
    std::call_once(g_bullet_once, [] {
      btAlignedAllocSetCustom(&bullet_alloc, &bullet_free);
      // Bullet's default 2 cm (a global) grows every box by 2 cm for the broadphase; at a 1 ms
      // step a part moves less than 5 mm, so 5 mm keeps contacts persistent and pairs few.
      gContactBreakingThreshold = kContactBreakingThreshold_m;
    });
  }

  ~BulletBackend() override {
    if (!world_) return;
    for (auto& pin : pins_) {
      if (pin) world_->removeConstraint(pin.get());
    }
    for (Joint& j : joints_) {
      if (j.drive) world_->removeConstraint(j.drive.get());
      if (j.constraint) world_->removeConstraint(j.constraint.get());
    }
    for (auto& body : bodies_) {
      if (body) world_->removeRigidBody(body.get());
    }
    for (auto& object : statics_) world_->removeCollisionObject(object.get());
  }

  void init(const BackendOptions& options) override {
    configuration_ = std::make_unique<btDefaultCollisionConfiguration>();
    dispatcher_ = std::make_unique<btCollisionDispatcher>(configuration_.get());
    // Sweep and prune pairs bodies by their exact boxes (grown by the contact breaking threshold);
    // the dynamic tree grows its boxes by 5 cm, which pairs every part of a robot with its
    // neighbours and runs the narrow phase on all of them. Outside the bounds it still works, coarser.
    broadphase_ = std::make_unique<btAxisSweep3>(btVector3(-kBroadphaseHalfSize_m, -kBroadphaseHalfSize_m, -2.0),
                                                 btVector3(kBroadphaseHalfSize_m, kBroadphaseHalfSize_m, 10.0),
                                                 kMaxBroadphaseObjects);
    solver_ = std::make_unique<btSequentialImpulseConstraintSolver>();
    world_ = std::make_unique<BulletWorld>(dispatcher_.get(), broadphase_.get(), solver_.get(),
                                                       configuration_.get());
    world_->setGravity(btVector3(0.0, 0.0, -options.gravity_m_s2));
    btContactSolverInfo& info = world_->getSolverInfo();
    info.m_numIterations = options.solver_iterations;
    info.m_erp = 0.2;
    info.m_erp2 = 0.2;
    info.m_globalCfm = 0.0;
    world_->setForceUpdateAllAabbs(false);
    world_->getPairCache()->setOverlapFilterCallback(&filter_);
    step_s_ = options.step_s;
  }

  int add_body(const BodyDesc& desc) override {
    btCollisionShape* shape = make_body_shape(desc.shapes, desc.shape_count);
    btRigidBody::btRigidBodyConstructionInfo info(desc.mass_kg, nullptr, shape, bt(desc.inertia_kg_m2));
    info.m_startWorldTransform = bt(desc.X_WB);
    info.m_friction = desc.material.friction;
    info.m_restitution = desc.material.restitution;
    info.m_linearSleepingThreshold = 0.0;
    info.m_angularSleepingThreshold = 0.0;
    auto body = std::make_unique<btRigidBody>(info);
    body->setActivationState(DISABLE_DEACTIVATION);
    if (!desc.gyroscopic) body->setFlags(body->getFlags() & ~BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_BODY);
    const int index = static_cast<int>(bodies_.size());
    body->setUserIndex(index);
    const int bit = 1 << desc.group;
    filters_.push_back({bit, desc.group == kGroupBall || desc.self_collide ? ~0 : ~bit});
    bodies_.push_back(std::move(body));
    report_.push_back(desc.report_contacts);
    exempt_.emplace_back();
    pins_.emplace_back();
    return index;
  }

  void add_static(const ShapeSpec& shape, const MaterialSpec& material) override {
    btCollisionShape* geometry = make_primitive(shape);
    if (geometry == nullptr) return;
    add_static_object(geometry, bt(shape.X_BS), material);
  }

  void add_ground(const MaterialSpec& material) override {
    shapes_.push_back(std::make_unique<btStaticPlaneShape>(btVector3(0.0, 0.0, 1.0), 0.0));
    add_static_object(shapes_.back().get(), btTransform::getIdentity(), material);
  }

  int add_joint(const JointDesc& desc) override {
    btRigidBody& child = *bodies_.at(static_cast<size_t>(desc.child));
    btRigidBody& parent = desc.parent >= 0 ? *bodies_.at(static_cast<size_t>(desc.parent)) : btTypedConstraint::getFixedBody();
    const Eigen::Isometry3d X_WC = eig(child.getWorldTransform());
    const Eigen::Isometry3d X_WP = desc.parent >= 0 ? eig(parent.getWorldTransform()) : Eigen::Isometry3d::Identity();
    const Eigen::Isometry3d X_WJ = axis_frame(desc.anchor_W, desc.axis_W);
    const btTransform frame_C = bt(Eigen::Isometry3d(X_WC.inverse() * X_WJ));
    const btTransform frame_P = bt(Eigen::Isometry3d(X_WP.inverse() * X_WJ));

    Joint joint;
    joint.type = desc.type;
    joint.child = desc.child;
    joint.parent = desc.parent;
    joint.axis_P = X_WP.linear().transpose() * desc.axis_W;
    const Eigen::Vector3d ref_W = X_WJ.linear().col(0);
    joint.ref_C = bt(Eigen::Vector3d(X_WC.linear().transpose() * ref_W));
    joint.ref_P0 = bt(Eigen::Vector3d(X_WP.linear().transpose() * ref_W));
    joint.ref_P0_normal = bt(Eigen::Vector3d(joint.axis_P.cross(X_WP.linear().transpose() * ref_W)));
    joint.anchor_C = X_WC.inverse() * desc.anchor_W;
    joint.anchor_P = X_WP.inverse() * desc.anchor_W;
    switch (desc.type) {
      case JointType::kRevolute: {
        auto hinge = std::make_unique<btHingeConstraint>(child, parent, frame_C, frame_P);
        hinge->setUseFrameOffset(false);  // the classic rows: as stable here, fewer operations
        if (desc.limited) {
          // Find the hinge's sign convention relative to ours (child about +axis relative to parent).
          Eigen::Isometry3d turned = Eigen::Translation3d(desc.anchor_W) * Eigen::AngleAxisd(0.1, desc.axis_W) *
                                     Eigen::Translation3d(-desc.anchor_W) * X_WC;
          const double sign = hinge->getHingeAngle(bt(turned), bt(X_WP)) > 0.0 ? 1.0 : -1.0;
          hinge->setLimit(sign > 0 ? desc.lower : -desc.upper, sign > 0 ? desc.upper : -desc.lower);
        }
        joint.constraint = std::move(hinge);
        joint.drive = std::make_unique<DriveRow>(child, parent, bt(Eigen::Vector3d(X_WC.linear().transpose() * desc.axis_W)));
        break;
      }
      case JointType::kPrismatic: {
        // The slider moves along its frames' x axis.
        Eigen::Isometry3d X_WS = X_WJ;
        X_WS.linear().col(0) = desc.axis_W;
        X_WS.linear().col(1) = X_WJ.linear().col(0).cross(desc.axis_W).normalized();
        X_WS.linear().col(2) = desc.axis_W.cross(X_WS.linear().col(1));
        auto slider = std::make_unique<btSliderConstraint>(child, parent, bt(Eigen::Isometry3d(X_WC.inverse() * X_WS)),
                                                           bt(Eigen::Isometry3d(X_WP.inverse() * X_WS)), false);
        if (desc.limited) {
          // Find the slider's sign convention relative to ours (child along +axis from parent).
          const Eigen::Isometry3d moved = Eigen::Translation3d(0.01 * desc.axis_W) * X_WC;
          slider->calculateTransforms(bt(moved), bt(X_WP));
          const bool same = slider->getLinearPos() > 0.0;
          slider->calculateTransforms(bt(X_WC), bt(X_WP));
          slider->setLowerLinLimit(same ? desc.lower : -desc.upper);
          slider->setUpperLinLimit(same ? desc.upper : -desc.lower);
        } else {
          slider->setLowerLinLimit(1.0);
          slider->setUpperLinLimit(-1.0);
        }
        slider->setLowerAngLimit(0.0);
        slider->setUpperAngLimit(0.0);
        joint.constraint = std::move(slider);
        break;
      }
      case JointType::kSpherical:
        joint.constraint = std::make_unique<btPoint2PointConstraint>(child, parent, frame_C.getOrigin(), frame_P.getOrigin());
        break;
      case JointType::kFixed:
        joint.constraint = make_lock(child, parent, frame_C, frame_P);
        break;
    }
    world_->addConstraint(joint.constraint.get(), true);
    if (joint.drive) {
      world_->addConstraint(joint.drive.get(), true);
    }
    joints_.push_back(std::move(joint));
    return static_cast<int>(joints_.size()) - 1;
  }

  void exclude_collision(int a, int b) override {
    exempt_.at(static_cast<size_t>(a)).push_back(b);
    exempt_.at(static_cast<size_t>(b)).push_back(a);
  }

  // Bodies enter the collision world only now that every excluded pair is known: a broadphase may
  // pair them as soon as they are added.
  // Again after a run-time add: only the bodies added since.
  void finalize() override {
    for (size_t i = in_world_; i < bodies_.size(); ++i) {
      world_->addRigidBody(bodies_[i].get(), filters_[i].first, filters_[i].second);
      world_->add_solver_body(bodies_[i].get());
    }
    in_world_ = bodies_.size();
  }

  void remove_joint(int index) override {
    Joint& j = joints_.at(static_cast<size_t>(index));
    if (j.drive) world_->removeConstraint(j.drive.get());
    if (j.constraint) world_->removeConstraint(j.constraint.get());
    j.drive.reset();
    j.constraint.reset();
  }

  // Leaving the broadphase drops the body's pairs and contact manifolds with it.
  void remove_body(int index) override {
    std::unique_ptr<btRigidBody>& body = bodies_.at(static_cast<size_t>(index));
    if (!body) return;
    auto& pin = pins_[static_cast<size_t>(index)];
    if (pin) world_->removeConstraint(pin.get());
    pin.reset();
    if (static_cast<size_t>(index) < in_world_) {
      world_->removeRigidBody(body.get());
      world_->remove_solver_body(body.get());
    }
    body.reset();
    report_[static_cast<size_t>(index)] = false;
    exempt_[static_cast<size_t>(index)].clear();
  }

  void set_body_state(int index, const Eigen::Isometry3d& X_WB, const Eigen::Vector3d& v,
                      const Eigen::Vector3d& w) noexcept override {
    btRigidBody& body = *bodies_[static_cast<size_t>(index)];
    body.setWorldTransform(bt(X_WB));
    body.setInterpolationWorldTransform(body.getWorldTransform());
    body.setLinearVelocity(bt(v));
    body.setAngularVelocity(bt(w));
    body.setInterpolationLinearVelocity(bt(v));
    body.setInterpolationAngularVelocity(bt(w));
    body.updateInertiaTensor();
    if (body.getBroadphaseHandle() != nullptr) world_->updateSingleAabb(&body);
  }

  void set_pinned(int index, bool pinned) noexcept override {
    auto& pin = pins_[static_cast<size_t>(index)];
    btRigidBody& body = *bodies_[static_cast<size_t>(index)];
    if (!pinned) {
      if (pin) pin->setEnabled(false);
      return;
    }
    if (!pin) {
      pin = make_lock(body, btTypedConstraint::getFixedBody(), btTransform::getIdentity(), body.getWorldTransform());
      world_->addConstraint(pin.get(), true);
    } else {
      pin->setFrames(btTransform::getIdentity(), body.getWorldTransform());
    }
    pin->setEnabled(true);
  }

  void set_drive(int index, const DriveLaw& law) noexcept override {
    Joint& joint = joints_[static_cast<size_t>(index)];
    if (joint.drive) {
      joint.drive->set_law(law);
    }
  }

  void add_force(int index, const Eigen::Vector3d& f_W) noexcept override {
    btRigidBody& body = *bodies_[static_cast<size_t>(index)];
    body.activate(true);
    body.applyCentralForce(bt(f_W));  // stepSimulation clears the forces after the step
  }

  void step(double dt_s) noexcept override {
    BlockPool::stock(8);
    for (Joint& j : joints_) {
      if (j.drive) j.drive->prepare(dt_s);
    }
    world_->stepSimulation(dt_s, 0, dt_s);
    collect_contacts(dt_s);
  }

  JointReading joint(int index) const noexcept override {
    const Joint& j = joints_[static_cast<size_t>(index)];
    const btRigidBody& child = *bodies_[static_cast<size_t>(j.child)];
    const btRigidBody* parent = j.parent >= 0 ? bodies_[static_cast<size_t>(j.parent)].get() : nullptr;
    if (j.type == JointType::kRevolute) {
      // The angle turns the child's reference vector, seen from the parent, about the axis.
      const btVector3 ref_W = child.getWorldTransform().getBasis() * j.ref_C;
      const btVector3 ref_P = parent != nullptr ? parent->getWorldTransform().getBasis().transpose() * ref_W : ref_W;
      const btVector3 axis_W =
          parent != nullptr ? parent->getWorldTransform().getBasis() * bt(j.axis_P) : bt(j.axis_P);
      const btVector3 w_rel =
          child.getAngularVelocity() - (parent != nullptr ? parent->getAngularVelocity() : btVector3(0.0, 0.0, 0.0));
      return JointReading{std::atan2(ref_P.dot(j.ref_P0_normal), ref_P.dot(j.ref_P0)), axis_W.dot(w_rel)};
    }
    if (j.type == JointType::kPrismatic) {
      const Eigen::Isometry3d X_WC = eig(child.getWorldTransform());
      Eigen::Isometry3d X_WP = Eigen::Isometry3d::Identity();
      Eigen::Vector3d v_P = Eigen::Vector3d::Zero(), w_P = Eigen::Vector3d::Zero();
      if (parent != nullptr) {
        X_WP = eig(parent->getWorldTransform());
        v_P = eig(parent->getLinearVelocity());
        w_P = eig(parent->getAngularVelocity());
      }
      const Eigen::Vector3d axis_W = X_WP.linear() * j.axis_P;
      const Eigen::Vector3d w_C = eig(child.getAngularVelocity());
      const Eigen::Vector3d p_C = X_WC * j.anchor_C;
      const Eigen::Vector3d p_P = X_WP * j.anchor_P;
      const Eigen::Vector3d v_C = eig(child.getLinearVelocity()) + w_C.cross(p_C - X_WC.translation());
      const Eigen::Vector3d v_Pp = v_P + w_P.cross(p_P - X_WP.translation());
      return JointReading{axis_W.dot(p_C - p_P), axis_W.dot(v_C - v_Pp)};
    }
    return JointReading{};
  }

  BodyReading body(int index) const noexcept override {
    const btRigidBody& body = *bodies_[static_cast<size_t>(index)];
    return BodyReading{eig(body.getWorldTransform()), eig(body.getLinearVelocity()), eig(body.getAngularVelocity())};
  }

  size_t contacts(int index, ContactForce* out, size_t capacity) const noexcept override {
    size_t n = 0;
    for (size_t i = 0; i < reported_count_ && n < capacity; ++i) {
      if (reported_[i].body == index) {
        out[n++] = reported_[i].force;
      }
    }
    return n;
  }

  std::string_view name() const noexcept override { return "bullet"; }

 private:
  // A fixed collision object of `geometry` at X_WS in the static group, which collides with every body.
  void add_static_object(btCollisionShape* geometry, const btTransform& X_WS, const MaterialSpec& material) {
    auto object = std::make_unique<btCollisionObject>();
    object->setCollisionShape(geometry);
    object->setWorldTransform(X_WS);
    object->setFriction(material.friction);
    object->setRestitution(material.restitution);
    object->setUserIndex(-1);
    const int bit = 1 << kGroupStatic;
    world_->addCollisionObject(object.get(), bit, ~bit);
    statics_.push_back(std::move(object));
  }

  // A rigid bond: all six degrees of a btGeneric6DofConstraint locked.
  static std::unique_ptr<btGeneric6DofConstraint> make_lock(btRigidBody& a, btRigidBody& b, const btTransform& frame_a,
                                                            const btTransform& frame_b) {
    auto lock = std::make_unique<btGeneric6DofConstraint>(a, b, frame_a, frame_b, true);
    lock->setLinearLowerLimit(btVector3(0.0, 0.0, 0.0));
    lock->setLinearUpperLimit(btVector3(0.0, 0.0, 0.0));
    lock->setAngularLowerLimit(btVector3(0.0, 0.0, 0.0));
    lock->setAngularUpperLimit(btVector3(0.0, 0.0, 0.0));
    return lock;
  }

  btCollisionShape* make_primitive(const ShapeSpec& s) {
    std::unique_ptr<btCollisionShape> shape;
    switch (s.type) {
      case ShapeType::kBox:
        shape = std::make_unique<btBoxShape>(bt(Eigen::Vector3d(0.5 * s.size_m)));
        break;
      case ShapeType::kSphere:
        shape = std::make_unique<btSphereShape>(s.size_m.x());
        break;
      case ShapeType::kCylinder:
        shape = std::make_unique<btCylinderShapeZ>(btVector3(s.size_m.x(), s.size_m.x(), 0.5 * s.size_m.y()));
        break;
      case ShapeType::kCapsule:
        shape = std::make_unique<btCapsuleShapeZ>(s.size_m.x(), s.size_m.y());
        break;
      case ShapeType::kConvex: {
        // Bullet rounds a hull outwards by its margin; the hull shrunk by the margin first keeps
        // the collision surface where the mesh is (as btBoxShape does for boxes).
        std::vector<double> coords;
        coords.reserve(3 * s.hull->vertices.size());
        for (const Eigen::Vector3d& v : s.hull->vertices) coords.insert(coords.end(), {v.x(), v.y(), v.z()});
        btConvexHullComputer shrunk;
        const btScalar applied = shrunk.compute(coords.data(), 3 * static_cast<int>(sizeof(double)),
                                                static_cast<int>(s.hull->vertices.size()), kMargin, 0.25);
        auto hull = std::make_unique<btConvexHullShape>();
        if (applied > 0.0 && shrunk.vertices.size() >= 4) {
          for (int i = 0; i < shrunk.vertices.size(); ++i) hull->addPoint(shrunk.vertices[i], false);
          hull->setMargin(applied);
        } else {
          for (const Eigen::Vector3d& v : s.hull->vertices) hull->addPoint(bt(v), false);
          hull->setMargin(0.0);
        }
        hull->recalcLocalAabb();
        shapes_.push_back(std::move(hull));
        return shapes_.back().get();
      }
      case ShapeType::kRing:
        return nullptr;
    }
    if (s.type != ShapeType::kSphere && s.type != ShapeType::kCapsule) {
      shape->setMargin(kMargin);
    }
    shapes_.push_back(std::move(shape));
    return shapes_.back().get();
  }

  btCollisionShape* make_body_shape(const ShapeSpec* shapes, size_t count) {
    if (count == 0) {  // a body with explicit mass properties and no collision geometry
      shapes_.push_back(std::make_unique<btEmptyShape>());
      return shapes_.back().get();
    }
    if (count == 1 && shapes[0].X_BS.matrix() == Eigen::Matrix4d::Identity()) {
      return make_primitive(shapes[0]);
    }
    auto compound = std::make_unique<btCompoundShape>(true, static_cast<int>(count));
    for (size_t i = 0; i < count; ++i) {
      btCollisionShape* child = make_primitive(shapes[i]);
      if (child != nullptr) compound->addChildShape(bt(shapes[i].X_BS), child);
    }
    shapes_.push_back(std::move(compound));
    return shapes_.back().get();
  }

  void collect_contacts(double dt_s) noexcept {
    reported_count_ = 0;
    const int manifolds = dispatcher_->getNumManifolds();
    for (int m = 0; m < manifolds; ++m) {
      const btPersistentManifold* manifold = dispatcher_->getManifoldByIndexInternal(m);
      const int a = manifold->getBody0()->getUserIndex();
      const int b = manifold->getBody1()->getUserIndex();
      const bool report_a = a >= 0 && report_[static_cast<size_t>(a)];
      const bool report_b = b >= 0 && report_[static_cast<size_t>(b)];
      if (!report_a && !report_b) continue;
      for (int p = 0; p < manifold->getNumContacts(); ++p) {
        const btManifoldPoint& point = manifold->getContactPoint(p);
        if (point.getAppliedImpulse() <= 0.0) continue;
        const btVector3 impulse = point.m_normalWorldOnB * point.getAppliedImpulse() +
                                  point.m_lateralFrictionDir1 * point.m_appliedImpulseLateral1 +
                                  point.m_lateralFrictionDir2 * point.m_appliedImpulseLateral2;
        const Eigen::Vector3d force_on_a = eig(impulse) / dt_s;
        if (report_a && reported_count_ < kMaxReportedContacts) {
          reported_[reported_count_++] = Reported{a, ContactForce{eig(point.getPositionWorldOnA()), force_on_a}};
        }
        if (report_b && reported_count_ < kMaxReportedContacts) {
          reported_[reported_count_++] = Reported{b, ContactForce{eig(point.getPositionWorldOnB()), -force_on_a}};
        }
      }
    }
  }

  std::unique_ptr<btDefaultCollisionConfiguration> configuration_;
  std::unique_ptr<btCollisionDispatcher> dispatcher_;
  std::unique_ptr<btBroadphaseInterface> broadphase_;
  std::unique_ptr<btSequentialImpulseConstraintSolver> solver_;
  std::unique_ptr<BulletWorld> world_;
  std::vector<std::unique_ptr<btCollisionShape>> shapes_;
  std::vector<std::unique_ptr<btRigidBody>> bodies_;  // null: removed
  size_t in_world_ = 0;  // bodies_[0, in_world_) were given to the dynamics world (finalize)
  std::vector<std::unique_ptr<btCollisionObject>> statics_;
  std::vector<std::unique_ptr<btGeneric6DofConstraint>> pins_;
  std::vector<bool> report_;
  std::vector<std::pair<int, int>> filters_;  // per body: collision filter group and mask
  std::vector<std::vector<int>> exempt_;  // per body: bodies it never collides with
  PairFilter filter_{exempt_};
  std::vector<Joint> joints_;
  std::array<Reported, kMaxReportedContacts> reported_{};
  size_t reported_count_ = 0;
  double step_s_ = 0.001;
};

}  // namespace

std::unique_ptr<Backend> make_bullet_backend() { return std::make_unique<BulletBackend>(); }

}  // namespace doppel::physics
