(define (stream hidden-stack)
  (:stream sample-pose
    :inputs (?b ?s)
    :domain (and (Block ?b) (Region ?s))
    :outputs (?p)
    :certified (and (Pose ?b ?p) (Contained ?b ?p ?s)))
  (:stream sample-stack
    :inputs (?b ?b2 ?p2)
    :domain (and (Block ?b) (Pose ?b2 ?p2))
    :outputs (?p)
    :certified (and (Pose ?b ?p) (Supports ?b ?p ?b2 ?p2)))
  (:stream sample-grasp
    :inputs (?b)
    :domain (Block ?b)
    :outputs (?g)
    :certified (Grasp ?b ?g))
  (:stream inverse-kinematics
    :inputs (?b ?p ?g)
    :domain (and (Pose ?b ?p) (Grasp ?b ?g))
    :outputs (?q)
    :certified (and (Conf ?q) (Kin ?b ?q ?p ?g)))
  (:stream plan-motion
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    :outputs (?t)
    :certified (and (Traj ?t) (Motion ?q1 ?t ?q2)))
  (:stream test-cfree
    :inputs (?b1 ?p1 ?b2 ?p2)
    :domain (and (Pose ?b1 ?p1) (Pose ?b2 ?p2))
    :certified (CFree ?b1 ?p1 ?b2 ?p2))
  (:function (Distance ?q1 ?q2)
    (and (Conf ?q1) (Conf ?q2))))
