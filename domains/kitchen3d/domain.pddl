; Kitchen3D: one or two Franka Pandas at a table (PyBullet) with cups of beads, bowls, blocks,
; a spoon, a stirrer and a faucet. Every action names the arm doing it as its LAST parameter
; ?r ((Arm ?r); the object's value is the arm index); each arm has its own (AtConf ?r ?q),
; (HandEmpty ?r) and (CanMove ?r). Continuous values come from streams (stream.pddl):
; placements, grasps, IK with the approach path, RRT-Connect motions (free and holding),
; learned pour and scoop controls turned into arm paths (follow-obj-path), engineered dump,
; stir and push paths, and collision tests used negated through derived predicates:
; UnsafePose (object footprints overlap) and UnsafeTraj (a path hits a movable object where
; it stands), so the planner sees which object is in the way and moves it.
; Two arms take turns: the streams check each arm against the other one resting at its home
; conf ((Home ?r ?q)), so an arm acts only while the other is at home (not (OtherBusy ?r)).
; An arm moves between a pick and a place of the same object (JustPicked / JustPlaced): a pick
; right after a place at the same conf (or the reverse) only undoes it, and would let a search
; chain carries through intermediate placements (place-pick-place) instead of one move.
(define (domain kitchen3d)
  (:requirements :strips :equality :negative-preconditions :derived-predicates :action-costs)
  (:predicates
    (Arm ?r) (Pourable ?o) (Receptacle ?o) (Graspable ?o) (Region ?r) (Stackable ?o ?r)
    (Spoon ?s) (Stirrer ?s) (Scoopable ?b) (Pushable ?o)
    (Pose ?o ?p) (Grasp ?o ?g) (Conf ?r ?q) (HoldConf ?r ?o ?g ?q) (Traj ?t)
    (Contained ?o ?p ?r) (InReach ?r ?o ?p) (Kin ?r ?o ?p ?g ?q ?a)
    (FreeMotion ?r ?q1 ?t ?q2) (HoldingMotion ?r ?o ?g ?q1 ?t ?q2)
    (PourKin ?r ?k ?g ?c ?p ?q ?a ?u)
    (ScoopKin ?r ?s ?g ?b ?p ?q1 ?q2 ?a ?u)
    (DumpKin ?r ?s ?g ?c ?p ?q ?a) (StirKin ?r ?s ?g ?c ?p ?q ?a)
    (PushKin ?r ?o ?p1 ?p2 ?q1 ?q2 ?a)
    (CFree ?o1 ?p1 ?o2 ?p2) (CFreeTraj ?t ?o2 ?p2)
    (AtPose ?o ?p) (AtGrasp ?r ?o ?g) (AtConf ?r ?q) (HandEmpty ?r) (CanMove ?r)
    (Contains ?o ?m) (Stirred ?c)
    (On ?o ?r) (Holding ?o) (UnsafePose ?o ?p) (UnsafeTraj ?t)
    (Home ?r ?q) (Busy ?r) (OtherBusy ?r) (JustPicked ?r) (JustPlaced ?r))
  (:functions (Distance ?r ?q1 ?q2) (total-cost))
  (:derived (On ?o ?r)
    (exists (?p) (and (Contained ?o ?p ?r) (AtPose ?o ?p))))
  (:derived (Holding ?o)
    (exists (?r ?g) (and (Arm ?r) (Grasp ?o ?g) (AtGrasp ?r ?o ?g))))
  (:derived (Busy ?r)
    (exists (?q) (and (Arm ?r) (AtConf ?r ?q) (not (Home ?r ?q)))))
  (:derived (OtherBusy ?r)
    (exists (?r2) (and (Arm ?r) (Arm ?r2) (not (= ?r ?r2)) (Busy ?r2))))
  (:derived (UnsafePose ?o ?p)
    (exists (?o2 ?p2) (and (Pose ?o ?p) (Pose ?o2 ?p2) (AtPose ?o2 ?p2) (not (= ?o ?o2))
                           (not (CFree ?o ?p ?o2 ?p2)))))
  (:derived (UnsafeTraj ?t)
    (exists (?o2 ?p2) (and (Traj ?t) (Pose ?o2 ?p2) (AtPose ?o2 ?p2)
                           (not (CFreeTraj ?t ?o2 ?p2)))))
  (:action move-free
    :parameters (?q1 ?t ?q2 ?r)
    :precondition (and (not (OtherBusy ?r)) (FreeMotion ?r ?q1 ?t ?q2) (AtConf ?r ?q1) (HandEmpty ?r) (CanMove ?r)
                       (not (UnsafeTraj ?t)))
    :effect (and (AtConf ?r ?q2) (not (AtConf ?r ?q1)) (not (CanMove ?r)) (not (JustPlaced ?r))
                 (increase (total-cost) (Distance ?r ?q1 ?q2))))
  (:action move-holding
    :parameters (?o ?g ?q1 ?t ?q2 ?r)
    :precondition (and (not (OtherBusy ?r)) (HoldingMotion ?r ?o ?g ?q1 ?t ?q2) (AtConf ?r ?q1) (AtGrasp ?r ?o ?g)
                       (CanMove ?r) (not (UnsafeTraj ?t)))
    :effect (and (AtConf ?r ?q2) (not (AtConf ?r ?q1)) (not (CanMove ?r)) (not (JustPicked ?r))
                 (increase (total-cost) (Distance ?r ?q1 ?q2))))
  (:action pick
    :parameters (?o ?p ?g ?q ?a ?r)
    :precondition (and (not (OtherBusy ?r)) (Kin ?r ?o ?p ?g ?q ?a) (AtPose ?o ?p) (HandEmpty ?r) (AtConf ?r ?q)
                       (not (JustPlaced ?r)) (not (UnsafeTraj ?a)))
    :effect (and (AtGrasp ?r ?o ?g) (CanMove ?r) (not (AtPose ?o ?p)) (not (HandEmpty ?r))
                 (JustPicked ?r) (increase (total-cost) 1)))
  (:action place
    :parameters (?o ?p ?g ?q ?a ?r)
    :precondition (and (not (OtherBusy ?r)) (Kin ?r ?o ?p ?g ?q ?a) (AtGrasp ?r ?o ?g) (AtConf ?r ?q)
                       (not (JustPicked ?r)) (not (UnsafePose ?o ?p)) (not (UnsafeTraj ?a)))
    :effect (and (AtPose ?o ?p) (HandEmpty ?r) (CanMove ?r) (not (AtGrasp ?r ?o ?g))
                 (JustPlaced ?r) (increase (total-cost) 1)))
  ; Learned (GoodPour): tilt the held cup about a pivot over the receptacle and back.
  ; New contents undo a stir.
  (:action pour
    :parameters (?k ?g ?c ?p ?q ?a ?u ?m ?r)
    :precondition (and (not (OtherBusy ?r)) (PourKin ?r ?k ?g ?c ?p ?q ?a ?u) (AtGrasp ?r ?k ?g) (AtConf ?r ?q)
                       (AtPose ?c ?p) (Contains ?k ?m) (not (UnsafeTraj ?a)))
    :effect (and (Contains ?c ?m) (not (Contains ?k ?m)) (not (Stirred ?c)) (CanMove ?r)
                 (increase (total-cost) 1)))
  ; Learned (GoodScoop): drag the held spoon through the bowl's beads and lift a spoonful;
  ; the arm ends above the bowl at ?q2 (the path is not reversed: that would spill).
  (:action scoop
    :parameters (?s ?g ?b ?p ?q1 ?q2 ?a ?u ?m ?r)
    :precondition (and (not (OtherBusy ?r)) (ScoopKin ?r ?s ?g ?b ?p ?q1 ?q2 ?a ?u) (AtGrasp ?r ?s ?g)
                       (AtConf ?r ?q1) (AtPose ?b ?p) (Contains ?b ?m) (not (UnsafeTraj ?a)))
    :effect (and (Contains ?s ?m) (AtConf ?r ?q2) (not (AtConf ?r ?q1)) (CanMove ?r)
                 (increase (total-cost) 1)))
  ; Engineered: roll the spoon over above the receptacle, and back.
  (:action dump
    :parameters (?s ?g ?c ?p ?q ?a ?m ?r)
    :precondition (and (not (OtherBusy ?r)) (DumpKin ?r ?s ?g ?c ?p ?q ?a) (AtGrasp ?r ?s ?g) (AtConf ?r ?q)
                       (AtPose ?c ?p) (Contains ?s ?m) (not (UnsafeTraj ?a)))
    :effect (and (Contains ?c ?m) (not (Contains ?s ?m)) (not (Stirred ?c)) (CanMove ?r)
                 (increase (total-cost) 1)))
  ; Engineered: the held stirrer goes down into the receptacle, circles, and comes back up.
  (:action stir
    :parameters (?s ?g ?c ?p ?q ?a ?r)
    :precondition (and (not (OtherBusy ?r)) (StirKin ?r ?s ?g ?c ?p ?q ?a) (AtGrasp ?r ?s ?g) (AtConf ?r ?q)
                       (AtPose ?c ?p) (not (UnsafeTraj ?a)))
    :effect (and (Stirred ?c) (CanMove ?r) (increase (total-cost) 1)))
  ; Engineered: the empty hand pushes the object along a straight line from ?p1 to ?p2.
  (:action push
    :parameters (?o ?p1 ?p2 ?q1 ?q2 ?a ?r)
    :precondition (and (not (OtherBusy ?r)) (PushKin ?r ?o ?p1 ?p2 ?q1 ?q2 ?a) (AtPose ?o ?p1) (HandEmpty ?r)
                       (AtConf ?r ?q1) (not (UnsafePose ?o ?p2)) (not (UnsafeTraj ?a)))
    :effect (and (AtPose ?o ?p2) (not (AtPose ?o ?p1)) (AtConf ?r ?q2) (not (AtConf ?r ?q1))
                 (CanMove ?r) (increase (total-cost) 1))))
