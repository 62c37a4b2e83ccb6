(define (stream kitchen3d)
  ; Engineered: placements in a table region, grasps of an object.
  (:stream sample-placement
    :inputs (?o ?r)
    :domain (Stackable ?o ?r)
    :outputs (?p)
    :certified (and (Pose ?o ?p) (Contained ?o ?p ?r)))
  (:stream sample-grasp
    :inputs (?o)
    :domain (Graspable ?o)
    :outputs (?g)
    :certified (Grasp ?o ?g))
  ; Verified IK of the pre-grasp and the Cartesian approach path into the grasp.
  (:stream inverse-kinematics
    :inputs (?o ?p ?g)
    :domain (and (Pose ?o ?p) (Grasp ?o ?g))
    :outputs (?q ?a)
    :certified (and (Conf ?q) (HoldConf ?o ?g ?q) (Traj ?a) (Kin ?o ?p ?g ?q ?a)))
  ; Fluent-free motions: RRT-Connect around the fixed scenery (movable objects: CFreeTraj).
  (:stream plan-free-motion
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    :outputs (?t)
    :certified (and (Traj ?t) (FreeMotion ?q1 ?t ?q2)))
  (:stream plan-holding-motion
    :inputs (?o ?g ?q1 ?q2)
    :domain (and (HoldConf ?o ?g ?q1) (HoldConf ?o ?g ?q2))
    :outputs (?t)
    :certified (and (Traj ?t) (HoldingMotion ?o ?g ?q1 ?t ?q2)))
  ; Learned GoodPour control, its cup path, and that path followed by the arm
  ; (follow-obj-path): the pour start conf and the arm path of the whole pour.
  (:stream sample-pour
    :inputs (?k ?g ?c ?p)
    :domain (and (Pourable ?k) (Grasp ?k ?g) (Receptacle ?c) (Pose ?c ?p))
    :outputs (?q ?a ?u)
    :certified (and (Conf ?q) (HoldConf ?k ?g ?q) (Traj ?a) (PourKin ?k ?g ?c ?p ?q ?a ?u)))
  (:stream test-cfree
    :inputs (?o1 ?p1 ?o2 ?p2)
    :domain (and (Pose ?o1 ?p1) (Pose ?o2 ?p2))
    :certified (CFree ?o1 ?p1 ?o2 ?p2))
  (:stream test-cfree-traj
    :inputs (?t ?o2 ?p2)
    :domain (and (Traj ?t) (Pose ?o2 ?p2))
    :certified (CFreeTraj ?t ?o2 ?p2))
  (:function (Distance ?q1 ?q2)
    (and (Conf ?q1) (Conf ?q2))))
