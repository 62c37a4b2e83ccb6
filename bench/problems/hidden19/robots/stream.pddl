(define (stream hidden-robots)
  (:stream sample-pose
    :inputs (?b ?s)
    :domain (and (Movable ?b) (Region ?s))
    :outputs (?p)
    :certified (and (Pose ?b ?p) (Contained ?b ?p ?s)))
  (:stream test-region
    :inputs (?b ?p ?s)
    :domain (and (Pose ?b ?p) (Region ?s))
    :certified (Contained ?b ?p ?s))
  (:stream sample-grasp
    :inputs (?b)
    :domain (Movable ?b)
    :outputs (?g)
    :certified (Grasp ?b ?g))
  (:stream inverse-kinematics
    :inputs (?r ?b ?p ?g)
    :domain (and (Robot ?r) (Pose ?b ?p) (Grasp ?b ?g))
    :outputs (?q)
    :certified (and (Conf ?r ?q) (Kin ?r ?b ?q ?p ?g)))
  (:stream plan-motion
    :inputs (?r ?q1 ?q2)
    :domain (and (Conf ?r ?q1) (Conf ?r ?q2))
    :outputs (?t)
    :certified (and (Traj ?t) (Motion ?r ?q1 ?t ?q2)))
  (:stream test-cfree
    :inputs (?b1 ?p1 ?b2 ?p2)
    :domain (and (Pose ?b1 ?p1) (Pose ?b2 ?p2))
    :certified (CFree ?b1 ?p1 ?b2 ?p2))
  (:function (Distance ?r ?q1 ?q2)
    (and (Conf ?r ?q1) (Conf ?r ?q2))))
