; 2D stacking with one free-flying gripper (issue #19's hidden suite). A pose is the block's
; bottom centre (x, y); a block rests on a region of the table (y = 0) or on another block.
; A block with another on top cannot be picked; collisions are ruled out only through the
; negated derived UnsafePose over the test-cfree stream (2D boxes).
(define (domain hidden-stack)
  (:requirements :strips :equality :negative-preconditions :derived-predicates :action-costs)
  (:predicates
    (Block ?b) (Region ?s) (Pose ?b ?p) (Grasp ?b ?g) (Conf ?q) (Traj ?t)
    (Kin ?b ?q ?p ?g) (Motion ?q1 ?t ?q2) (Contained ?b ?p ?s) (Supports ?b ?p ?b2 ?p2)
    (CFree ?b1 ?p1 ?b2 ?p2)
    (AtPose ?b ?p) (AtGrasp ?b ?g) (AtConf ?q) (HandEmpty) (CanMove)
    (In ?b ?s) (On ?b ?b2) (Covered ?b) (Supported ?b ?p) (UnsafePose ?b ?p))
  (:functions (Distance ?q1 ?q2) (total-cost))
  (:derived (In ?b ?s)
    (exists (?p) (and (Contained ?b ?p ?s) (AtPose ?b ?p))))
  (:derived (On ?b ?b2)
    (exists (?p ?p2) (and (Supports ?b ?p ?b2 ?p2) (AtPose ?b ?p) (AtPose ?b2 ?p2))))
  (:derived (Covered ?b)
    (exists (?b2) (and (Block ?b2) (On ?b2 ?b))))
  (:derived (Supported ?b ?p)
    (or (exists (?s) (Contained ?b ?p ?s))
        (exists (?b2 ?p2) (and (Supports ?b ?p ?b2 ?p2) (AtPose ?b2 ?p2)))))
  (:derived (UnsafePose ?b ?p)
    (exists (?b2 ?p2) (and (Pose ?b ?p) (Pose ?b2 ?p2) (AtPose ?b2 ?p2) (not (= ?b ?b2))
                           (not (CFree ?b ?p ?b2 ?p2)))))
  (:action move
    :parameters (?q1 ?t ?q2)
    :precondition (and (Motion ?q1 ?t ?q2) (AtConf ?q1) (CanMove))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Distance ?q1 ?q2))))
  (:action pick
    :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?q ?p ?g) (AtPose ?b ?p) (HandEmpty) (AtConf ?q)
                       (not (Covered ?b)))
    :effect (and (AtGrasp ?b ?g) (CanMove) (not (AtPose ?b ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))
  (:action place
    :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?q ?p ?g) (AtGrasp ?b ?g) (AtConf ?q) (Supported ?b ?p)
                       (not (UnsafePose ?b ?p)))
    :effect (and (AtPose ?b ?p) (HandEmpty) (CanMove) (not (AtGrasp ?b ?g))
                 (increase (total-cost) 1))))
