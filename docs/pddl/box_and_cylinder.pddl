; Wipe a three-segment table on which a box and a cylinder stand.
; Segments are numbered as declared (s1, s2, s3); MOVE goes around the ring s1 -> s2 -> s3 -> s1.
(define (problem box-and-cylinder)
  (:domain tableclean)
  (:objects s1 s2 s3 - segment
            box1 - box
            can1 - cylinder)
  (:init (next s1 s2) (next s2 s3) (next s3 s1)
         (arm-at s2)
         (on box1 s1)
         (on can1 s2)
         (wiped s1))
  (:goal (and (wiped s1) (wiped s2) (wiped s3))))
