// DART .skel -> MuJoCo MJCF translation that mirrors DART 6.12's SkelParser, so that both
// engines see the same kinematic tree, masses, inertias and contact geometry.
//
// Conventions found in DART 6.12 (the MuJoCo side reproduces each of them):
//  - <transformation>x y z r p y</transformation>: T = [R | t], t = (x y z),
//    R = Rx(r) * Ry(p) * Rz(y) (intrinsic XYZ, math::eulerXYZToMatrix).
//  - body <transformation> is the body's world pose at q = 0, pre-multiplied by the skeleton's
//    <transformation>; joint <transformation> is child body -> joint frame (T_CJ), and
//    T_parent_child(q) = T_P^-1 * T_C * T_CJ * J(q) * T_CJ^-1.
//  - euler joint: axis_order "xyz" -> Rx(q0) Ry(q1) Rz(q2), dofs <j>_x,_y,_z;
//    "zyx" -> Rz(q0) Ry(q1) Rx(q2), dofs <j>_z,_y,_x. Other orders are rejected by DART.
//  - universal: R(axis, q0) * R(axis2, q1), dofs <j>_1, <j>_2. revolute/prismatic: one dof <j>.
//  - ball: exp(q) (rotation vector, dofs <j>_x,_y,_z); MuJoCo quaternion = R_CJ exp(q) R_CJ^T.
//  - free: [exp(q[0:3]) | q[3:6]] in the joint frame; velocities are body-frame twists.
//  - position limits are read but NOT enforced by default (Joint::mIsPositionLimitEnforced =
//    false): the MJCF carries range with limited="false".
//  - <inertia> absent: mass 1, COM 0, moment = identity. <moment_of_inertia> absent: moment of
//    the body's first shape (visualization shapes come first) for the body mass, ignoring the
//    shape's placement.
//  - ellipsoid <size> are diameters; capsule <height> is the cylindrical part only; cylinder
//    <height> is the full height along z.
//  - <init_pos>/<init_vel> (and <dof><position initial=..>) are the state after loading, not
//    the reference configuration: the MJCF keeps q = 0 as reference and stores DART's initial
//    state in <keyframe><key name="init">.
//  - skeletons never self-collide (self-collision check is off by default): each mobile
//    skeleton with two or more colliding bodies gets a contype bit of its own (31 at most);
//    <friction_coeff> is not read by DART 6.12, so every shape has DART's default friction 1 (=
//    MuJoCo's default).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace stance {

struct SkelInput {
  std::string path;                                  // .skel file; "dart://sample/..." is resolved
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // world translation of the whole file
};

struct SkelTranslation {
  std::string mjcf;                                        // full MJCF document text
  double timestep = 0.001;                                 // s, <physics><time_step>
  Eigen::Vector3d gravity = Eigen::Vector3d(0, 0, -9.81);  // m/s^2, <physics><gravity>
  std::vector<std::string> immobile_skeletons;             // <mobile>false</mobile> ones
};

// the most bodies one .skel file may hold: a bound on loading time and memory on both engines
constexpr size_t kMaxSkelBodies = 1000;

// Reads a .skel file as DART 6.12's SkelParser would and checks it before DART sees it:
// well-formed XML, counts of numbers, finite values, sizes, masses and inertias > 0, known joint
// and shape types, booleans, dof indices, init_pos/init_vel sizes, mesh files, soft-shape
// counts, the time step, joint cycles and the body count. What only DART can simulate (soft
// bodies, meshes, cones, pyramids, planar joints, gravity off) passes. Throws InputError
// "file:line: ..".
void check_skel_for_dart(const std::string& path);

// Composes the files into one MuJoCo world. The SKEL world frame is kept as is (no
// rotation). Body and joint names are the SKEL names; they must be unique across all files.
// Throws InputError "file:line: message" for malformed input (check_skel_for_dart's checks) and
// for what MuJoCo cannot represent.
SkelTranslation skel_to_mjcf(const std::vector<SkelInput>& files);

// `stance convert`: translates one .skel file and writes the MJCF text to out_path.
void write_mjcf_file(const std::string& skel_path, const std::string& out_path);

}  // namespace stance
