// People as a depth sensor sees them: articulated bodies (legs, torso, neck, head, upper and lower
// arms, hands) in the gestures a match brings (standing, walking, reaching, an arm raised above the
// head or held out, a hand at the head, a referee's flag held up), with hair that returns little or
// no depth and clothes that return less when dark. Sizes from adult anthropometry: segment lengths
// as shares of the height (hip 0.53, shoulder 0.82, upper arm 0.19, forearm 0.16), head 21 cm
// across, as wide as a size 5 ball.
#pragma once

#include <optional>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "kinect3d/sim/scene.h"

namespace kinect3d::sim {

enum class Gesture { kDown, kWalkingSwing, kReaching, kRaised, kHeldOut, kHandAtHead, kRefereeFlag };

// An arm's pose in the body frame (x right, y forward, z up): raised this far from hanging straight
// down, in the direction swing from sideways (0) to forward (pi/2), the elbow bent this far towards
// the front.
struct ArmPose {
  double raise_rad = 0.1;
  double swing_rad = 0.0;
  double elbow_rad = 0.2;
  bool flag = false;  // holds a referee's flag (a 45 x 30 cm panel on a stick)
  static ArmPose of(Gesture gesture, double side);
};

struct Person {
  Eigen::Vector3d feet_m = Eigen::Vector3d::Zero();  // on the floor between the feet, field frame
  double yaw_rad = 0.0;                              // facing +y of the field at 0
  double height_m = 1.75;
  double build = 1.0;       // widths and girths scale by this
  double stride_rad = 0.0;  // thighs swing this far either way (walking)
  ArmPose left_arm, right_arm;
  double clothes_dropout = 0.0;  // chance a pixel on the clothes returns nothing (dark clothes)
  double hair_dropout = 1.0;     // on the hair, which covers the top and back of the head

  std::vector<Shape> shapes() const;
};

// A person of random height (1.55-1.95 m), build, clothes, hair and gestures, at feet_m facing yaw.
Person randomPerson(std::mt19937& random, const Eigen::Vector3d& feet_m, double yaw_rad);

// Random scenes of people round a robot, seeded: 5-8 people at 0.8-6 m, many cut by the view's
// edges, close ones by its top and bottom, walking slowly, in random gestures and clothes, before a
// wall or an empty hall; the sensor's height, tilt and range (5.5-9.5 m) random too. The ball:
enum class CrowdBall {
  kNone,             // no ball: anything found is a phantom
  kThrownFromHands,  // held out by a person facing the robot, then thrown
  kOverAHead,        // lobbed 0.3 m over a person's head
  kFromTheBorder,    // enters the view from its side, in the air
};
Scene crowdScene(int seed, CrowdBall ball);
const char* crowdBallName(CrowdBall ball);
// The scene a name such as people_over_a_head_5 gives (its kind, then its seed), if it is one.
std::optional<Scene> crowdSceneNamed(const std::string& name);

// Gesture names as scene files write them: down, walking, reaching, raised, held_out, hand_at_head, flag.
Gesture gestureNamed(const std::string& name);
std::vector<std::string> gestureNames();

}  // namespace kinect3d::sim
