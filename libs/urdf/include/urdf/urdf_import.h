#pragma once
// URDF import: completes a robot file whose figure takes its body from a URDF (Figure.urdf,
// libs/proto/body.proto) with plain bodies and links, so that physics, body and camera see the same
// figure as for a hand-written robot and need no URDF knowledge. urdfdom parses the URDF (TinyXML
// first, for the line and column of an XML error), assimp reads collision meshes (STL, DAE, OBJ,
// ...), physics/convex_hull.h reduces each mesh to its hull.
//
// Its own library (not in proto/) because it pulls in urdfdom, TinyXML and assimp, which the
// schema and the text-file loader, linked by every tool, do not need; it depends on proto (the
// messages it writes) and on physics only for the hull. gateway's load_robot() calls it.
//
// Mapping (docs/physics.md "URDF import"): every URDF link with an <inertial> becomes a Body of
// the same name, its frame the link frame, pose from the joint origins at all joints 0;
// <collision> box / cylinder / sphere become shapes, <mesh> a Convex of its hull vertices (scale
// applied); the first <visual>'s material colour becomes Body.color. A link without <inertial>
// and without <collision> joined by a fixed joint is a frame of its neighbour (sensors may still
// name it; their mounts are moved onto the body). Every joint becomes a Link (anchor and axis in
// the robot frame); revolute / continuous / prismatic joints need an entry in Urdf.joint.
// Setup code: allocates; not thread-safe (console_bridge's log handler is global).

#include <string>

#include "proto/robot_file.h"

namespace doppel::urdf {

// Fills `file`'s figure from its Figure.urdf; does nothing when the figure has none. Throws
// std::invalid_argument "robot-file:line:column: Urdf.<field>: <urdf-file>: <element>: <what>"
// for a missing or broken URDF or mesh, a joint with no servo, a servo with no joint, ... ;
// generated messages report the location of the Urdf message or of their joint entry.
void expand(proto::RobotFile& file);

// proto::RobotFile::load(path), then expand().
proto::RobotFile load_robot_file(const std::string& path);
proto::RobotFile parse_robot_file(const std::string& text, const std::string& path);

}  // namespace doppel::urdf
