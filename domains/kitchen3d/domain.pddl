; Kitchen3D: a Franka Panda at a table (PyBullet) with cups of beads, bowls, blocks and a
; faucet. Continuous values come from streams (stream.pddl): placements, grasps, IK with the
; approach path, RRT-Connect motions (free and holding), learned pour controls turned into
; arm paths (follow-obj-path), and collision tests used negated through derived predicates:
; UnsafePose (object footprints overlap) and UnsafeTraj (a path hits a movable object where
; it stands), so the planner sees which object is in the way and moves it.
(define (domain kitchen3d)
  (:requirements :strips :equality :negative-preconditions :derived-predicates :action-costs)
  (:predicates
    (Pourable ?o) (Receptacle ?o) (Graspable ?o) (Region ?r) (Stackable ?o ?r)
    (Pose ?o ?p) (Grasp ?o ?g) (Conf ?q) (HoldConf ?o ?g ?q) (Traj ?t)
    (Contained ?o ?p ?r) (Kin ?o ?p ?g ?q ?a)
    (FreeMotion ?q1 ?t ?q2) (HoldingMotion ?o ?g ?q1 ?t ?q2)
    (PourKin ?k ?g ?c ?p ?q ?a ?u)
    (CFree ?o1 ?p1 ?o2 ?p2) (CFreeTraj ?t ?o2 ?p2)
    (AtPose ?o ?p) (AtGrasp ?o ?g) (AtConf ?q) (HandEmpty) (CanMove)
    (Contains ?o ?m)
    (On ?o ?r) (Holding ?o) (UnsafePose ?o ?p) (UnsafeTraj ?t))
  (:functions (Distance ?q1 ?q2) (total-cost))
  (:derived (On ?o ?r)
    (exists (?p) (and (Contained ?o ?p ?r) (AtPose ?o ?p))))
  (:derived (Holding ?o)
    (exists (?g) (and (Grasp ?o ?g) (AtGrasp ?o ?g))))
  (:derived (UnsafePose ?o ?p)
    (exists (?o2 ?p2) (and (Pose ?o ?p) (Pose ?o2 ?p2) (AtPose ?o2 ?p2) (not (= ?o ?o2))
                           (not (CFree ?o ?p ?o2 ?p2)))))
  (:derived (UnsafeTraj ?t)
    (exists (?o2 ?p2) (and (Traj ?t) (Pose ?o2 ?p2) (AtPose ?o2 ?p2)
                           (not (CFreeTraj ?t ?o2 ?p2)))))
  (:action move-free
    :parameters (?q1 ?t ?q2)
    :precondition (and (FreeMotion ?q1 ?t ?q2) (AtConf ?q1) (HandEmpty) (CanMove)
                       (not (UnsafeTraj ?t)))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Distance ?q1 ?q2))))
  (:action move-holding
    :parameters (?o ?g ?q1 ?t ?q2)
    :precondition (and (HoldingMotion ?o ?g ?q1 ?t ?q2) (AtConf ?q1) (AtGrasp ?o ?g) (CanMove)
                       (not (UnsafeTraj ?t)))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Distance ?q1 ?q2))))
  (:action pick
    :parameters (?o ?p ?g ?q ?a)
    :precondition (and (Kin ?o ?p ?g ?q ?a) (AtPose ?o ?p) (HandEmpty) (AtConf ?q)
                       (not (UnsafeTraj ?a)))
    :effect (and (AtGrasp ?o ?g) (CanMove) (not (AtPose ?o ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))
  (:action place
    :parameters (?o ?p ?g ?q ?a)
    :precondition (and (Kin ?o ?p ?g ?q ?a) (AtGrasp ?o ?g) (AtConf ?q)
                       (not (UnsafePose ?o ?p)) (not (UnsafeTraj ?a)))
    :effect (and (AtPose ?o ?p) (HandEmpty) (CanMove) (not (AtGrasp ?o ?g))
                 (increase (total-cost) 1)))
  ; Learned (GoodPour): tilt the held cup about a pivot over the receptacle and back.
  (:action pour
    :parameters (?k ?g ?c ?p ?q ?a ?u ?m)
    :precondition (and (PourKin ?k ?g ?c ?p ?q ?a ?u) (AtGrasp ?k ?g) (AtConf ?q)
                       (AtPose ?c ?p) (Contains ?k ?m) (not (UnsafeTraj ?a)))
    :effect (and (Contains ?c ?m) (not (Contains ?k ?m)) (CanMove)
                 (increase (total-cost) 1))))
