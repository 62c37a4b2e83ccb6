; Kitchen2D: a free-flying gripper in a 2D kitchen (Box2D) with cups, a spoon, a stirrer,
; a faucet and a coaster. Continuous values come from streams (stream.pddl): poses and
; grasps, gripper confs above the reserved columns with their approach paths, RRT-Connect
; motions, and learned pour/scoop/push controls. A block can be pushed off the table (push:
; the closed gripper slides it over an edge; it ends on the floor).
(define (domain kitchen2d)
  (:requirements :strips :equality :negative-preconditions :derived-predicates :action-costs)
  (:predicates
    (Cup ?c) (Pitcher ?k) (Bowl ?b) (Spoon ?s) (Stirrer ?s) (Block ?o) (Edge ?e)
    (Graspable ?o) (Region ?r)
    (Stackable ?o ?r) (Workspace ?r) (Dispenses ?r ?m)
    (Pose ?o ?p) (Grasp ?o ?g) (Conf ?q) (HoldConf ?o ?g ?q) (Traj ?t)
    (Contained ?o ?p ?r) (Kin ?o ?p ?g ?q ?a)
    (FreeMotion ?q1 ?t ?q2) (HoldingMotion ?o ?g ?q1 ?t ?q2) (CFree ?o1 ?p1 ?o2 ?p2)
    (PourKin ?k ?g ?c ?p ?q ?a ?u) (ScoopKin ?s ?g ?b ?p ?q ?a ?u)
    (DumpKin ?s ?g ?c ?p ?q ?a ?u) (StirKin ?s ?g ?c ?p ?q ?a ?u) (PushKin ?o ?p ?e ?q ?a ?u)
    (AtPose ?o ?p) (AtGrasp ?o ?g) (AtConf ?q) (HandEmpty) (CanMove)
    (Contains ?o ?m) (Stirred ?c) (OffTable ?o)
    (On ?o ?r) (Holding ?o) (UnsafePose ?o ?p))
  (:functions (Distance ?q1 ?q2) (HoldDistance ?o ?g ?q1 ?q2) (total-cost))
  (:derived (On ?o ?r)
    (exists (?p) (and (Contained ?o ?p ?r) (AtPose ?o ?p))))
  (:derived (Holding ?o)
    (exists (?g) (and (Grasp ?o ?g) (AtGrasp ?o ?g))))
  ; A pose is unsafe when it is not certified collision-free with another object's pose.
  (:derived (UnsafePose ?o ?p)
    (exists (?o2 ?p2) (and (Pose ?o ?p) (Pose ?o2 ?p2) (AtPose ?o2 ?p2) (not (= ?o ?o2))
                           (not (CFree ?o ?p ?o2 ?p2)))))
  (:action move-free
    :parameters (?q1 ?t ?q2)
    :precondition (and (FreeMotion ?q1 ?t ?q2) (AtConf ?q1) (HandEmpty) (CanMove))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Distance ?q1 ?q2))))
  (:action move-holding
    :parameters (?o ?g ?q1 ?t ?q2)
    :precondition (and (HoldingMotion ?o ?g ?q1 ?t ?q2) (AtConf ?q1) (AtGrasp ?o ?g)
                       (CanMove))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove))
                 (increase (total-cost) (HoldDistance ?o ?g ?q1 ?q2))))
  (:action pick
    :parameters (?o ?p ?g ?q ?a)
    :precondition (and (Kin ?o ?p ?g ?q ?a) (AtPose ?o ?p) (HandEmpty) (AtConf ?q))
    :effect (and (AtGrasp ?o ?g) (CanMove) (not (AtPose ?o ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))
  (:action place
    :parameters (?o ?p ?g ?q ?a)
    :precondition (and (Kin ?o ?p ?g ?q ?a) (AtGrasp ?o ?g) (AtConf ?q)
                       (not (UnsafePose ?o ?p)))
    :effect (and (AtPose ?o ?p) (HandEmpty) (CanMove) (not (AtGrasp ?o ?g))
                 (increase (total-cost) 1)))
  ; Push a block off the table over edge ?e with the empty, closed hand (learned GoodPush);
  ; the hand comes back up to ?q.
  (:action push
    :parameters (?o ?p ?e ?q ?a ?u)
    :precondition (and (PushKin ?o ?p ?e ?q ?a ?u) (AtPose ?o ?p) (HandEmpty) (AtConf ?q))
    :effect (and (OffTable ?o) (not (AtPose ?o ?p)) (CanMove) (increase (total-cost) 1)))
  ; The faucet fills a cup standing under it (the hand is free and away).
  (:action fill
    :parameters (?c ?p ?r ?m)
    :precondition (and (Cup ?c) (Contained ?c ?p ?r) (Dispenses ?r ?m) (AtPose ?c ?p)
                       (HandEmpty))
    :effect (and (Contains ?c ?m) (not (Stirred ?c)) (CanMove) (increase (total-cost) 1)))
  (:action pour
    :parameters (?k ?g ?c ?p ?q ?a ?u ?m)
    :precondition (and (PourKin ?k ?g ?c ?p ?q ?a ?u) (AtGrasp ?k ?g) (AtConf ?q)
                       (AtPose ?c ?p) (Contains ?k ?m))
    :effect (and (Contains ?c ?m) (not (Contains ?k ?m)) (not (Stirred ?c)) (CanMove)
                 (increase (total-cost) 1)))
  (:action scoop
    :parameters (?s ?g ?b ?p ?q ?a ?u ?m)
    :precondition (and (ScoopKin ?s ?g ?b ?p ?q ?a ?u) (AtGrasp ?s ?g) (AtConf ?q)
                       (AtPose ?b ?p) (Contains ?b ?m))
    :effect (and (Contains ?s ?m) (CanMove) (increase (total-cost) 1)))
  (:action dump
    :parameters (?s ?g ?c ?p ?q ?a ?u ?m)
    :precondition (and (DumpKin ?s ?g ?c ?p ?q ?a ?u) (AtGrasp ?s ?g) (AtConf ?q)
                       (AtPose ?c ?p) (Contains ?s ?m))
    :effect (and (Contains ?c ?m) (not (Contains ?s ?m)) (not (Stirred ?c)) (CanMove)
                 (increase (total-cost) 1)))
  (:action stir
    :parameters (?s ?g ?c ?p ?q ?a ?u)
    :precondition (and (StirKin ?s ?g ?c ?p ?q ?a ?u) (AtGrasp ?s ?g) (AtConf ?q)
                       (AtPose ?c ?p))
    :effect (and (Stirred ?c) (CanMove) (increase (total-cost) 1))))
